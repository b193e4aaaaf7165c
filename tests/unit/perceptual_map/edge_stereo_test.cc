#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <tuple>
#include <vector>

#include "perception/perceptual_map/edge_stereo.h"
#include "tests/support/planar_world.h"

namespace epmap {
namespace {

TEST(EdgeStereo, TriangulationFollowsEquationsOneAndTwo) {
  perceptual_map::StereoCamera cam;
  cam.fx = cam.fy = 250.0;
  cam.cx = 160;
  cam.cy = 120;
  cam.baseline_m = 0.12;
  // Eq. 1: z = b f / d; Eq. 2: x = (c - c0) b / d.
  const Eigen::Vector3d p = perceptual_map::Triangulate(cam, 200.0, 140.0, 10.0);
  EXPECT_DOUBLE_EQ(p.z(), 0.12 * 250.0 / 10.0);
  EXPECT_DOUBLE_EQ(p.x(), (200.0 - 160.0) * 0.12 / 10.0);
  EXPECT_DOUBLE_EQ(p.y(), (140.0 - 120.0) * p.z() / 250.0);
}

// A textured wall 3 m ahead of a level camera: edge points are matched, and their depth is
// the wall's within a few centimetres (sub-pixel edges, 8x supersampled rendering).
TEST(EdgeStereo, EdgePointsOfAWallAheadLieOnIt) {
  const testing::PlanarWorld world({{{3.0, -5.0}, {3.0, 5.0}, 3.0}});
  const auto cam = testing::BumblebeeLikeCamera();
  Eigen::Isometry3d T_world_cam = testing::BaseInWorld({0, 0, 0}) * testing::CameraOnBase(0);
  T_world_cam.translation() = Eigen::Vector3d(0, 0, 1);
  Eigen::Isometry3d T_world_right = T_world_cam;
  T_world_right.translation() += T_world_cam.linear().col(0) * cam.baseline_m;
  const cv::Mat left = world.Render(T_world_cam, cam, 1);
  const cv::Mat right = world.Render(T_world_right, cam, 2);
  perceptual_map::EdgeStereoStats stats;
  const auto points = perceptual_map::MatchEdgePoints(left, right, cam, {}, &stats);
  ASSERT_GT(points.size(), 1000u);
  EXPECT_GT(stats.left_edges, points.size());
  size_t near = 0;
  for (const auto& p : points) near += std::abs(p.p_cam.z() - 3.0) < 0.05;
  EXPECT_GT(near, points.size() * 95 / 100);
}

// Two door jambs on a plain wall, 4 px disparity: the left image's second jamb looks exactly like
// the right image's first (the true first jamb is a shade darker, the true second one a pixel
// wider, its side face in view). The mutual check then pairs the second jamb with the first, a
// point 11 times nearer than the wall. With reject_contested the right edges both left jambs
// claim are dropped, and no such point is left.
TEST(EdgeStereo, RejectingContestedMatchesDropsTheJambMatchedAcrossTheDoor) {
  const auto image = [](std::initializer_list<std::tuple<int, int, uint8_t>> bars) {
    cv::Mat img(20, 200, CV_8UC1, cv::Scalar(180));
    for (const auto& [from, to, grey] : bars) img.colRange(from, to).setTo(grey);
    return img;
  };
  const cv::Mat left = image({{100, 104, 60}, {140, 144, 64}});
  const cv::Mat right = image({{96, 100, 64}, {135, 140, 64}});
  const auto cam = testing::BumblebeeLikeCamera();
  const auto farthest_disparity = [&](bool reject_contested) {
    perceptual_map::EdgeStereoParams p;
    p.reject_contested = reject_contested;
    float d = 0;
    for (const auto& e : perceptual_map::MatchEdgePoints(left, right, cam, p)) {
      d = std::max(d, e.disparity);
    }
    return d;
  };
  EXPECT_GT(farthest_disparity(false), 40.0F);  // the jamb matched across the door
  EXPECT_LT(farthest_disparity(true), 10.0F);
}

// A far, slanted surface with a smooth texture (a sum of sinusoids of 8-40 px periods, as the
// simulator's band-limited textures) and sensor noise: its disparity d(u) = 4 + 0.03 (u - 160)
// px. A smooth pattern's gradient peak is broad, so noise moves it; the window's grey levels
// pin the disparity down better. Area-sampled: each pixel averages 8 samples across it.
cv::Mat SmoothSlantedSurface(bool right_image) {
  const auto profile = [](double x) {
    double v = 0;
    for (int k = 0; k < 12; ++k) {
      const double period = 8.0 + 32.0 * testing::Unit(testing::Hash(7, k));
      const double phase = 2 * std::numbers::pi * testing::Unit(testing::Hash(8, k));
      v += 12.0 * std::sin(2 * std::numbers::pi * x / period + phase);
    }
    return 128 + v;
  };
  constexpr double kD0 = 4.0, kSlope = 0.03, kU0 = 160.0;
  cv::Mat img(60, 320, CV_32FC1);
  for (int u = 0; u < img.cols; ++u) {
    double acc = 0;
    for (int k = 0; k < 8; ++k) {
      const double x = u - 0.5 + (k + 0.5) / 8;
      // The right image at x shows the surface point that the left sees at x_l, x_l - d(x_l) = x.
      acc += profile(right_image ? (x + kD0 - kU0 * kSlope) / (1 - kSlope) : x);
    }
    img.col(u).setTo(acc / 8);
  }
  cv::Mat noise(img.size(), CV_32FC1);
  cv::RNG rng(right_image ? 2 : 1);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 2.0);
  cv::Mat out;
  cv::Mat noisy = img + noise;
  noisy.convertTo(out, CV_8UC1);
  return out;
}

TEST(EdgeStereo, RefiningOverTheWindowMakesDisparitiesOfSmoothTexturesMoreAccurate) {
  const cv::Mat left = SmoothSlantedSurface(false), right = SmoothSlantedSurface(true);
  const auto cam = testing::BumblebeeLikeCamera();
  const auto median_error = [&](double refine_px) {
    perceptual_map::EdgeStereoParams p;
    p.refine_disparity_px = refine_px;
    std::vector<double> errors;
    for (const auto& e : perceptual_map::MatchEdgePoints(left, right, cam, p)) {
      errors.push_back(std::abs(e.disparity - (4.0 + 0.03 * (e.u - 160.0))));
    }
    EXPECT_GT(errors.size(), 300u);
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    return errors[errors.size() / 2];
  };
  const double edges = median_error(0);
  const double refined = median_error(1.0);
  std::printf("median |disparity error|: edge locations %.3f px, refined over the window %.3f px\n",
              edges, refined);
  EXPECT_LT(refined, 0.8 * edges);
  perceptual_map::EdgeStereoParams bad;
  bad.refine_disparity_px = -1;
  EXPECT_THROW(perceptual_map::MatchEdgePoints(left, right, cam, bad), std::invalid_argument);
}

TEST(EdgeStereo, PointsBeyondTheRangeLimitAreDropped) {
  const testing::PlanarWorld world({{{3.0, -5.0}, {3.0, 5.0}, 3.0}});
  const auto cam = testing::BumblebeeLikeCamera();
  Eigen::Isometry3d T_world_cam = testing::CameraOnBase(0);
  T_world_cam.translation() = Eigen::Vector3d(0, 0, 1);
  Eigen::Isometry3d T_world_right = T_world_cam;
  T_world_right.translation() += T_world_cam.linear().col(0) * cam.baseline_m;
  perceptual_map::EdgeStereoParams p;
  p.max_range_m = 2.5;  // the wall is at 3 m (the paper's limit is 20 m)
  perceptual_map::EdgeStereoStats stats;
  const auto points = perceptual_map::MatchEdgePoints(
      world.Render(T_world_cam, cam, 1), world.Render(T_world_right, cam, 2), cam, p, &stats);
  size_t beyond = 0;
  for (const auto& e : points) beyond += e.p_cam.norm() > 2.5;
  EXPECT_EQ(beyond, 0u);
  EXPECT_GT(stats.rejected_range, 1000u);
}

TEST(EdgeStereo, BlankImagesGiveNoPointsAndBadInputIsRefused) {
  const auto cam = testing::BumblebeeLikeCamera();
  const cv::Mat blank(240, 320, CV_8UC1, cv::Scalar(128));
  EXPECT_TRUE(perceptual_map::MatchEdgePoints(blank, blank, cam, {}).empty());
  EXPECT_THROW(perceptual_map::MatchEdgePoints(cv::Mat(), blank, cam, {}), std::invalid_argument);
  EXPECT_THROW(perceptual_map::MatchEdgePoints(blank, cv::Mat(120, 160, CV_8UC1), cam, {}),
               std::invalid_argument);
  auto no_baseline = cam;
  no_baseline.baseline_m = 0;
  EXPECT_THROW(perceptual_map::MatchEdgePoints(blank, blank, no_baseline, {}),
               std::invalid_argument);
}

// A straight edge 30 degrees from the horizontal (the base of a wall seen in perspective),
// shifted by 6.4 px between the images: matched with the default slope limit (edges 18 degrees
// or more from horizontal), not with a limit of 45 degrees.
TEST(EdgeStereo, SlantedEdgesAreMatchedDownToEighteenDegrees) {
  const auto render = [](double shift) {
    cv::Mat img(120, 300, CV_8UC1);
    const double cot = 1.0 / std::tan(30.0 * std::numbers::pi / 180.0);
    for (int v = 0; v < img.rows; ++v) {
      for (int u = 0; u < img.cols; ++u) {
        // Area-sampled step: grey 60 left of the line x = 40 + cot * v + shift, 190 right.
        double acc = 0;
        for (int k = 0; k < 16; ++k) {
          const double x = u + (k + 0.5) / 16 - 0.5;
          acc += x < 40 + cot * v + shift ? 60 : 190;
        }
        img.at<uint8_t>(v, u) = static_cast<uint8_t>(acc / 16);
      }
    }
    return img;
  };
  const cv::Mat left = render(0), right = render(-6.4);
  const auto cam = testing::BumblebeeLikeCamera();
  const auto points = perceptual_map::MatchEdgePoints(left, right, cam, {});
  ASSERT_GT(points.size(), 50u);
  double sum = 0;
  for (const auto& p : points) {
    EXPECT_NEAR(p.disparity, 6.4, 0.3);  // along the row, a slanted edge is less precise
    sum += p.disparity;
  }
  EXPECT_NEAR(sum / static_cast<double>(points.size()), 6.4, 0.05);
  perceptual_map::EdgeStereoParams steep;
  steep.max_slope = 1.0;
  EXPECT_TRUE(perceptual_map::MatchEdgePoints(left, right, cam, steep).empty());
}

TEST(EdgeStereo, SubPixelEdgeLocation) {
  // A vertical step edge between columns 40 and 41 blurred by an exact box: its location is
  // recovered to a tenth of a pixel.
  cv::Mat img(20, 80, CV_32FC1);
  for (int c = 0; c < 80; ++c) img.col(c).setTo(c < 40 ? 50.0F : (c == 40 ? 110.0F : 200.0F));
  perceptual_map::EdgeStereoParams p;
  p.blur_sigma_px = 1.0;
  const auto rows = perceptual_map::DetectRowEdges(img, p);
  ASSERT_EQ(rows[10].size(), 1u);
  // Grey 110 at column 40 = 40% of the step: the edge is at 40.1 (pixel centres at integers,
  // the step crosses column 40's cell 60% of the way from its left side).
  EXPECT_NEAR(rows[10][0].u, 40.1, 0.1);
}

}  // namespace
}  // namespace epmap
