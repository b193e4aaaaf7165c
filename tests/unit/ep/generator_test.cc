#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "perception/ep/generator/disparity_fill.h"
#include "perception/ep/generator/ep_generator.h"
#include "tests/unit/ep/synthetic_scene.h"

namespace epmap {
namespace {

using ep::MapState;
using ep::Prediction;
using ep::PredictionParams;

// The map of a rendered frame with its true disparity.
MapState StateOf(const testing::SyntheticScene& scene, const cv::Mat& left,
                 const cv::Mat& disparity, int image_step) {
  MapState s;
  ep::SetPointsFromDisparity(disparity, &s);
  s.flags = cv::Mat(disparity.size(), CV_8U, cv::Scalar(0));
  s.flags.setTo(ep::kMeasured, disparity > 0);
  s.image = left;
  s.accumulated = cv::Mat::zeros(ep::ComparisonGrid(scene.camera(), image_step), CV_32F);
  return s;
}

// Mean |L_- - L| over the valid pixels of the comparison grid.
double MeanError(const Prediction& p, const cv::Mat& actual, int step) {
  double sum = 0;
  int n = 0;
  for (int i = 0; i < p.image.rows; ++i) {
    for (int j = 0; j < p.image.cols; ++j) {
      if (!p.image_valid.at<uint8_t>(i, j)) continue;
      sum += std::abs(p.image.at<float>(i, j) - actual.at<uint8_t>(i * step, j * step));
      ++n;
    }
  }
  return n ? sum / n : 1e9;
}

TEST(EpGenerator, StillCameraPredictsTheSameFrame) {
  const testing::SyntheticScene scene;
  cv::Mat l, r, d;
  const Eigen::Isometry3d T = testing::HeadPose(0, 0);
  scene.Render(T, &l, &r, &d);
  for (int step : {1, 2}) {
    PredictionParams params;
    params.image_step = step;
    const Prediction p = ep::Predict(StateOf(scene, l, d, step), Eigen::Isometry3d::Identity(),
                                     scene.camera(), params);
    EXPECT_EQ(cv::countNonZero(p.holes), 0);
    cv::Mat diff;
    cv::absdiff(p.disparity, d, diff);
    double max_diff = 0;
    cv::minMaxLoc(diff, nullptr, &max_diff);
    EXPECT_LT(max_diff, 1e-3);
    EXPECT_LT(MeanError(p, l, step), 1e-3);
  }
}

// A turning head: the predicted image matches the rendered next frame, the predicted disparity
// the true one, and the newly visible border is a hole on the side the view turns to.
TEST(EpGenerator, PredictsTheNextFrameOfATurningHead) {
  const testing::SyntheticScene scene;
  cv::Mat l0, r0, d0, l1, r1, d1;
  const Eigen::Isometry3d T0 = testing::HeadPose(0.0, 0.0), T1 = testing::HeadPose(0.03, 0.01);
  scene.Render(T0, &l0, &r0, &d0);
  scene.Render(T1, &l1, &r1, &d1);
  const Prediction p = ep::Predict(StateOf(scene, l0, d0, 2), T1.inverse() * T0, scene.camera());
  EXPECT_LT(MeanError(p, l1, 2), 4.0);  // grey levels, texture contrast ~60
  int close = 0, valid = 0;
  for (int v = 0; v < d1.rows; ++v) {
    for (int u = 0; u < d1.cols; ++u) {
      const float e = p.disparity.at<float>(v, u);
      if (!std::isfinite(e)) continue;
      ++valid;
      close += std::abs(e - d1.at<float>(v, u)) < 0.5F;
    }
  }
  EXPECT_GT(valid, d1.total() * 0.85);
  EXPECT_GT(close, valid * 0.97);
  // Yaw 0.03 rad at fx = 256 reveals ~8 columns on one side only.
  const int left_holes = cv::countNonZero(p.holes(cv::Rect(0, 0, 4, d1.rows)));
  const int right_holes = cv::countNonZero(p.holes(cv::Rect(d1.cols - 4, 0, 4, d1.rows)));
  EXPECT_GT(std::max(left_holes, right_holes), 3 * d1.rows);
  EXPECT_LT(std::min(left_holes, right_holes), d1.rows / 4);
}

TEST(EpGenerator, BrokenValuesNeverComeOutAsPredictions) {
  const testing::SyntheticScene scene;
  cv::Mat l, r, d;
  scene.Render(testing::HeadPose(0, 0), &l, &r, &d);
  MapState s = StateOf(scene, l, d, 2);
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  s.disparity.at<float>(100, 100) = inf;                         // at the camera
  s.disparity.at<float>(100, 101) = nan;                         // none
  s.disparity.at<float>(100, 102) = -1;                          // behind the camera
  s.disparity.at<float>(100, 103) = 1e-30F;                      // at infinity
  s.disparity.at<float>(100, 104) = 1e30F;                       // at the camera, finite
  s.offsets.at<cv::Vec2s>(100, 105) = cv::Vec2s(32767, -32768);  // far from its pixel
  s.accumulated.at<float>(50, 50) = nan;
  const Prediction p = ep::Predict(s, testing::HeadPose(0.01, 0).inverse(), scene.camera());
  for (int v = 0; v < p.disparity.rows; ++v) {
    for (int u = 0; u < p.disparity.cols; ++u) {
      const float x = p.disparity.at<float>(v, u), g = p.geometry.at<float>(v, u);
      // Unknown is NaN, anything else is a finite positive disparity.
      ASSERT_TRUE(std::isnan(x) || (std::isfinite(x) && x > 0)) << u << "," << v;
      ASSERT_EQ(std::isnan(g), p.holes.at<uint8_t>(v, u) != 0) << u << "," << v;
      ASSERT_EQ(g > 0, !p.holes.at<uint8_t>(v, u)) << u << "," << v;
    }
  }
  cv::Mat finite_c = p.accumulated == p.accumulated;
  EXPECT_EQ(cv::countNonZero(finite_c), static_cast<int>(p.accumulated.total()));
  cv::Mat finite_l = p.image == p.image;
  EXPECT_EQ(cv::countNonZero(finite_l), static_cast<int>(p.image.total()));
}

TEST(EpGenerator, PointsKeepTheirSubPixelPositionsFromFrameToFrame) {
  // A wall at 20 px of disparity; the camera slides so that it moves 0.25 px a frame in the
  // image. Rounded to pixel centres each frame, it would never move at all.
  const testing::SyntheticScene scene;
  const cv::Size size(scene.camera().width, scene.camera().height);
  const float wall_d = 20.0F;
  cv::Mat l(size, CV_8U, cv::Scalar(128));
  MapState s = StateOf(scene, l, cv::Mat(size, CV_32F, cv::Scalar(wall_d)), 2);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = 0.25 * scene.camera().baseline_m / wall_d;  // du = fx t_x / z
  const int u = size.width / 2, v = size.height / 2;
  constexpr float kUnit = 1.0F / ep::kOffsetScale;
  for (int frame = 1; frame <= 4; ++frame) {
    const Prediction p = ep::Predict(s, T, scene.camera());
    s.disparity = p.geometry.clone();
    s.offsets = p.offsets.clone();
    s.flags = p.flags.clone();
    // Where the point held by the pixel lies from its centre: 0.25, -0.5 (or 0.5), -0.25, 0.
    const float ou = static_cast<float>(s.offsets.at<cv::Vec2s>(v, u)[0]) * kUnit;
    const float expected = frame == 1 ? 0.25F : frame == 3 ? -0.25F : 0.0F;
    if (frame == 2) {
      EXPECT_NEAR(std::abs(ou), 0.5F, 4 * kUnit) << frame;
    } else {
      EXPECT_NEAR(ou, expected, 4 * kUnit) << frame;
    }
    EXPECT_NEAR(s.offsets.at<cv::Vec2s>(v, u)[1] * kUnit, 0.0F, 4 * kUnit) << frame;
    EXPECT_NEAR(s.disparity.at<float>(v, u), wall_d, 1e-3F) << frame;
  }
  // After four frames the wall has moved one whole pixel: the first column is uncovered.
  EXPECT_TRUE(std::isnan(s.disparity.at<float>(v, 0)));
  EXPECT_NEAR(s.disparity.at<float>(v, 1), wall_d, 1e-3F);
}

TEST(EpGenerator, RejectsInconsistentInput) {
  const testing::SyntheticScene scene;
  cv::Mat l, r, d;
  scene.Render(testing::HeadPose(0, 0), &l, &r, &d);
  const MapState good = StateOf(scene, l, d, 2);
  Eigen::Isometry3d bad_motion = Eigen::Isometry3d::Identity();
  bad_motion.translation().x() = std::nan("");
  EXPECT_THROW(ep::Predict(good, bad_motion, scene.camera()), std::invalid_argument);
  MapState small = good;
  small.image = l(cv::Rect(0, 0, 100, 100)).clone();
  EXPECT_THROW(ep::Predict(small, Eigen::Isometry3d::Identity(), scene.camera()),
               std::invalid_argument);
  MapState wrong_grid = good;
  wrong_grid.accumulated = cv::Mat::zeros(l.size(), CV_32F);  // full size, but step is 2
  EXPECT_THROW(ep::Predict(wrong_grid, Eigen::Isometry3d::Identity(), scene.camera()),
               std::invalid_argument);
  MapState wrong_offsets = good;
  wrong_offsets.offsets = cv::Mat::zeros(l.size(), CV_32FC2);
  EXPECT_THROW(ep::Predict(wrong_offsets, Eigen::Isometry3d::Identity(), scene.camera()),
               std::invalid_argument);
  PredictionParams params;
  params.image_step = 3;
  EXPECT_THROW(ep::Predict(good, Eigen::Isometry3d::Identity(), scene.camera(), params),
               std::invalid_argument);
}

TEST(DisparityFill, InterpolatesOneSurfaceAndTakesTheBackgroundAtEdges) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat d = (cv::Mat_<float>(2, 7) << 10, nan, nan, 11, nan, 30, 30,  //
               nan, 5, nan, nan, 25, nan, nan);
  const cv::Mat f = ep::FillUnknownDisparity(d);
  EXPECT_NEAR(f.at<float>(0, 1), 10 + 1.0F / 3, 1e-5);  // one surface: linear
  EXPECT_NEAR(f.at<float>(0, 2), 10 + 2.0F / 3, 1e-5);
  EXPECT_FLOAT_EQ(f.at<float>(0, 4), 11);  // 11 | 30: an edge, the farther side
  EXPECT_FLOAT_EQ(f.at<float>(1, 0), 5);   // only one side known
  EXPECT_FLOAT_EQ(f.at<float>(1, 2), 5);
  EXPECT_FLOAT_EQ(f.at<float>(1, 6), 25);
}

TEST(DisparityFill, OnePixelAtATimeGivesTheRowsValuesToTheBit) {
  // Random rows with gaps of every length, one surface or an edge across them, gaps at both
  // ends, rows with nothing known; pixels asked for in order and out of order.
  cv::RNG rng(7);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int width = 97;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<float> row(width), filled(width);
    const double known_share = trial % 10 == 0 ? 0.0 : rng.uniform(0.05, 0.95);
    float level = rng.uniform(1.0F, 60.0F);
    for (int u = 0; u < width; ++u) {
      if (rng.uniform(0.0, 1.0) < 0.05) level = rng.uniform(1.0F, 60.0F);  // an edge
      const double r = rng.uniform(0.0, 1.0);
      row[u] = r < known_share ? level + rng.uniform(-1.5F, 1.5F) : (r < 0.9 ? nan : -1.0F);
    }
    ep::FillUnknownDisparityRow(row.data(), filled.data(), width);
    ep::RowGap gap;
    for (int u = 0; u < width; ++u) {
      const float one = ep::FilledDisparityAt(row.data(), width, u, &gap);
      if (std::isnan(filled[u])) {
        EXPECT_TRUE(std::isnan(one)) << "trial " << trial << " u " << u;
      } else {
        EXPECT_EQ(one, filled[u]) << "trial " << trial << " u " << u;
      }
    }
    ep::RowGap fresh_gap;
    for (int u = width - 1; u >= 0; u -= 3) {
      const float one = ep::FilledDisparityAt(row.data(), width, u, &fresh_gap);
      if (!std::isnan(filled[u])) {
        EXPECT_EQ(one, filled[u]);
      }
    }
  }
}

}  // namespace
}  // namespace epmap
