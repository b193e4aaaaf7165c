#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

#include "clients/sim/random.h"
#include "clients/sim/renderer.h"
#include "clients/sim/sensor.h"
#include "clients/sim/stereo_shot.h"
#include "clients/sim/texture.h"
#include "clients/sim/texture_library.h"

namespace epmap::sim {
namespace {

PinholeCamera Camera() {
  return {100, 80, 100.0, 100.0, 49.5, 39.5};
}

// A grey texture whose value is the texel column (a ramp), so that the sampled value tells
// where on the texture a pixel landed.
Scene RampScene() {
  Scene scene;
  scene.channels = 1;
  cv::Mat ramp(8, 256, CV_8UC1);
  for (int x = 0; x < 256; ++x) ramp.col(x).setTo(x);
  scene.textures.emplace_back(ramp);
  return scene;
}

// A quad in the plane z = depth, x in [x0, x1], y in [y0, y1], facing the camera at the origin.
Quad FrontQuad(double x0, double x1, double y0, double y1, double depth) {
  Quad q;
  q.origin = {x0, y0, depth};
  q.edge_u = {x1 - x0, 0, 0};
  q.edge_v = {0, y1 - y0, 0};
  q.tex_origin = {-0.5, -0.5};
  q.tex_span = {256, 8};
  return q;
}

TEST(Renderer, FrontoParallelQuadHasExactDepthAndOutline) {
  Scene scene = RampScene();
  scene.quads.push_back(FrontQuad(-0.5, 0.5, -0.2, 0.2, 2.0));
  RenderOutput out;
  Render(scene, {}, Camera(), Eigen::Isometry3d::Identity(), &out);
  // Projected outline: x in [49.5 - 25, 49.5 + 25), y in [39.5 - 10, 39.5 + 10).
  for (int y = 0; y < 80; ++y) {
    for (int x = 0; x < 100; ++x) {
      const bool inside = x >= 25 && x <= 74 && y >= 30 && y <= 49;
      EXPECT_EQ(out.inv_depth.at<float>(y, x), inside ? 0.5F : 0.0F) << x << "," << y;
    }
  }
  // Texture coordinate across the face: s = -0.5 + 256 a with a = (X + 0.5) / 1.
  for (int x = 30; x < 70; x += 7) {
    const double X = 2.0 * (x - 49.5) / 100.0;
    const double s = -0.5 + 256 * (X + 0.5);
    // A footprint of 5 texels per pixel: the sampler blends mip levels of a linear ramp, which
    // keeps its value (away from the wrap-around).
    EXPECT_NEAR(out.radiance.at<float>(40, x), s, 0.6) << x;
  }
}

TEST(Renderer, NearerFaceWinsAndBackFacesAreCulled) {
  Scene scene = RampScene();
  scene.quads.push_back(FrontQuad(-1, 1, -1, 1, 3.0));
  Quad near = FrontQuad(-0.1, 0.1, -0.1, 0.1, 1.0);
  near.object = 7;
  RenderOutput out;
  Render(scene, {near}, Camera(), Eigen::Isometry3d::Identity(), &out);
  EXPECT_FLOAT_EQ(out.inv_depth.at<float>(40, 50), 1.0F);
  EXPECT_EQ(out.object.at<uint8_t>(40, 50), 7);
  EXPECT_FLOAT_EQ(out.inv_depth.at<float>(20, 20), 1.0F / 3.0F);
  EXPECT_EQ(out.object.at<uint8_t>(20, 20), 0);
  // Turned around, the near quad is seen from behind: culled unless two-sided.
  std::swap(near.edge_u, near.edge_v);
  near.origin = {-0.1, -0.1, 1.0};
  Render(scene, {near}, Camera(), Eigen::Isometry3d::Identity(), &out);
  EXPECT_FLOAT_EQ(out.inv_depth.at<float>(40, 50), 1.0F / 3.0F);
  near.two_sided = true;
  Render(scene, {near}, Camera(), Eigen::Isometry3d::Identity(), &out);
  EXPECT_FLOAT_EQ(out.inv_depth.at<float>(40, 50), 1.0F);
}

TEST(Renderer, GroundPlaneReachingBehindTheCameraIsClippedAndExact) {
  // Camera 1.2 m above a floor that extends behind it: y points down, the floor is y = 1.2.
  Scene scene = RampScene();
  Quad floor;
  floor.origin = {-20, 1.2, -5};
  floor.edge_u = {0, 0, 40};  // seen from above (from y < 1.2): right x down must face -y
  floor.edge_v = {40, 0, 0};
  floor.tex_span = {4000, 4000};
  ASSERT_LT(floor.normal().y(), 0);
  scene.quads.push_back(floor);
  RenderOutput out;
  const PinholeCamera cam = Camera();
  Render(scene, {}, cam, Eigen::Isometry3d::Identity(), &out);
  for (int y = 0; y < 80; ++y) {
    for (int x = 0; x < 100; x += 9) {
      // 1/z = (y - cy) / (fy h) below the horizon up to the floor's far edge (z = 35 m).
      const double expected = y > cam.cy ? (y - cam.cy) / (cam.fy * 1.2) : 0.0;
      if (expected > 0 && expected < 1 / 34.9) continue;
      EXPECT_NEAR(out.inv_depth.at<float>(y, x), expected, 1e-6) << x << "," << y;
    }
  }
}

TEST(Texture, BandLimitedNoiseIsPeriodicAndHasNoEnergyAboveTheCutoff) {
  Rng rng(3, Stream::kTextures);
  textures::Spectrum sp;
  sp.cutoff = 0.25;
  const cv::Mat n = textures::BandLimitedNoise(128, 128, sp, rng);
  cv::Scalar mean, stddev;
  cv::meanStdDev(n, mean, stddev);
  EXPECT_NEAR(mean[0], 0.0, 1e-5);
  EXPECT_NEAR(stddev[0], 1.0, 1e-5);
  cv::Mat spectrum;
  cv::dft(n, spectrum, cv::DFT_COMPLEX_OUTPUT);
  double above = 0, total = 0;
  for (int v = 0; v < 128; ++v) {
    for (int u = 0; u < 128; ++u) {
      const double fu = (u <= 64 ? u : u - 128) / 128.0, fv = (v <= 64 ? v : v - 128) / 128.0;
      const cv::Vec2f c = spectrum.at<cv::Vec2f>(v, u);
      const double e = c[0] * c[0] + c[1] * c[1];
      total += e;
      if (std::hypot(fu, fv) > sp.cutoff + 1.0 / 128) above += e;
    }
  }
  EXPECT_LT(above / total, 1e-9);
  // Periodic: the step across the wrap-around is like any step inside.
  double wrap = 0, inside = 0;
  for (int y = 0; y < 128; ++y) {
    wrap += std::abs(n.at<float>(y, 0) - n.at<float>(y, 127));
    inside += std::abs(n.at<float>(y, 64) - n.at<float>(y, 63));
  }
  EXPECT_LT(wrap, 2 * inside);
}

TEST(Texture, RefusesSidesThatAreNotPowersOfTwoAndBuildsAPyramid) {
  EXPECT_THROW(Texture(cv::Mat(100, 64, CV_8UC1, cv::Scalar(1))), std::invalid_argument);
  EXPECT_THROW(Texture(cv::Mat(64, 64, CV_32FC1, cv::Scalar(1))), std::invalid_argument);
  const Texture t(cv::Mat(64, 256, CV_8UC3, cv::Scalar(10, 20, 30)));
  EXPECT_EQ(t.channels(), 3);
  EXPECT_EQ(t.levels(), 5);  // 64x256, 32x128, 16x64, 8x32, 4x16 (sides stay >= 4)
  float out[4];
  t.Sample(3.3, 7.9, 30.0, out);  // any level of a flat texture is the same colour
  EXPECT_NEAR(out[0], 10, 1e-4);
  EXPECT_NEAR(out[2], 30, 1e-4);
}

TEST(Sensor, NoiseHasTheRequestedSpreadAndTheGainScales) {
  const cv::Mat radiance(200, 200, CV_32FC1, cv::Scalar(100));
  SensorModel sensor;
  sensor.noise_sigma = 2.0;
  const cv::Mat a = Expose(radiance, 1.1, sensor, Rng(1, Stream::kImageNoise, 0));
  cv::Scalar mean, stddev;
  cv::meanStdDev(a, mean, stddev);
  EXPECT_NEAR(mean[0], 110, 0.1);
  EXPECT_NEAR(stddev[0], std::sqrt(4.0 + 1.0 / 12), 0.15);  // noise plus quantisation
  const cv::Mat b = Expose(radiance, 1.1, sensor, Rng(1, Stream::kImageNoise, 0));
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  const cv::Mat c = Expose(radiance, 1.1, sensor, Rng(1, Stream::kImageNoise, 1));
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0);
}

// A plain quad (grey 228) on the background (128) whose left side projects to column 39.9: the
// pixel spanning [39.5, 40.5] is 60 % covered.
SimFrame ShootPlainQuad(int supersample) {
  static const Scene scene = [] {
    Scene s;
    s.channels = 1;
    s.textures.emplace_back(cv::Mat(8, 8, CV_8UC1, cv::Scalar(228)));
    s.quads.push_back(FrontQuad(2.0 * (39.9 - 49.5) / 100.0, 0.6, -0.2, 0.2, 2.0));
    return s;
  }();
  StereoShot shot;
  shot.scene = &scene;
  shot.camera = Camera();
  shot.T_world_cam1.translation() = Eigen::Vector3d(0.1, 0, 0);
  shot.sensor.blur_sigma_px = 0;
  shot.sensor.noise_sigma = 0;
  shot.rectified = true;
  shot.baseline = 0.1;
  shot.supersample = supersample;
  SimFrame f;
  ShootStereo(shot, &f);
  return f;
}

TEST(StereoShot, SupersamplingPutsASilhouetteBetweenPixelsAndKeepsTheTruthAtTheCentre) {
  const SimFrame one = ShootPlainQuad(1);
  const SimFrame three = ShootPlainQuad(3);
  // One sample per pixel: the silhouette snaps to the pixel grid (column 40 is all quad).
  EXPECT_EQ(one.left.at<uint8_t>(40, 39), 128);
  EXPECT_EQ(one.left.at<uint8_t>(40, 40), 228);
  // 3 x 3 samples at 39.67, 40.00, 40.33: two of three columns see the quad.
  EXPECT_NEAR(three.left.at<uint8_t>(40, 40), 128 + 100 * 2.0 / 3.0, 0.6);
  EXPECT_EQ(three.left.at<uint8_t>(40, 39), 128);
  EXPECT_EQ(three.left.at<uint8_t>(40, 41), 228);
  // The ground truth is the pixel centre's, the same as without supersampling.
  EXPECT_EQ(cv::norm(one.gt_disparity, three.gt_disparity, cv::NORM_INF), 0);
  EXPECT_FLOAT_EQ(three.gt_disparity.at<float>(40, 40), 100 * 0.1 / 2.0);
  EXPECT_TRUE(std::isnan(three.gt_disparity.at<float>(40, 39)));
  EXPECT_THROW(ShootPlainQuad(2), std::invalid_argument);
}

}  // namespace
}  // namespace epmap::sim
