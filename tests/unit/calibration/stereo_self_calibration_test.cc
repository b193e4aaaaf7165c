// Sec. III-A end to end on rendered textured scenes: SIFT -> F_K gate -> 8-point RANSAC -> E ->
// chirality -> acceptance near the prior -> rectification, one or several frames, with and
// without the baseline-direction prior. Renders and runs SIFT: labelled slow.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

#include "perception/calibration/stereo_self_calibration.h"
#include "tests/unit/calibration/stereo_test_rig.h"

namespace epmap::calibration {
namespace {

using namespace testing;

TEST(StereoSelfCalibration, RecoversTheExtrinsicsFromABiasedPriorAndRectifies) {
  const auto truth = TrueExtrinsics();
  const auto prior = Perturbed(truth, 1.2);
  const StereoView view = RenderView(testing::MakeDepthScene(21), truth, prior);
  const CameraIntrinsics cam = Camera();
  const auto r = SelfCalibrateStereo(cam, cam, {view});
  EXPECT_LT(RotationAngleDeg(r.model.T_cam0_cam1.linear(), truth.linear()), 0.2);
  EXPECT_LT(DirectionAngleDeg(r.model.T_cam0_cam1.translation(), truth.translation()), 1.0);
  EXPECT_NEAR(r.model.T_cam0_cam1.translation().norm(), prior.translation().norm(), 1e-12);
  EXPECT_NEAR(r.model.rotation_deviation_deg, 1.2, 0.2);
  EXPECT_GT(r.model.inliers, 100);
  EXPECT_LT(r.model.rms_sampson_px, 0.5);
  EXPECT_GT(r.prior_consistent_matches, r.model.inliers - 1);

  // Rectified with the recovered model the rows line up; with the biased prior they do not.
  cv::Mat rl, rr;
  MakeRectifier(cam, cam, r.model.T_cam0_cam1).Rectify(view.left, view.right, rl, rr);
  const double recovered = MedianVerticalOffset(rl, rr);
  MakeRectifier(cam, cam, prior).Rectify(view.left, view.right, rl, rr);
  const double biased = MedianVerticalOffset(rl, rr);
  EXPECT_LT(recovered, 0.5);
  EXPECT_GT(biased, 2.0);
}

TEST(StereoSelfCalibration, UndistortsBeforeMatching) {
  // The same scene seen through radial distortion: rendered ideal, then warped so that pixel
  // (u, v) of the raw image shows the ideal image at undistort(u, v).
  CameraIntrinsics cam = Camera();
  cam.distortion = {-0.28, 0.09, 0.0005, -0.0003, 0.0};
  const auto truth = TrueExtrinsics();
  StereoView view = RenderView(testing::MakeDepthScene(31), truth, Perturbed(truth, 0.8));
  std::vector<cv::Point2f> grid;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x)
      grid.emplace_back(static_cast<float>(x), static_cast<float>(y));
  }
  cv::Matx33d k;
  for (int i = 0; i < 9; ++i) k.val[i] = cam.k(i / 3, i % 3);
  std::vector<cv::Point2f> ideal;
  cv::undistortPoints(grid, ideal, k, cam.distortion, cv::noArray(), k);
  const cv::Mat map = cv::Mat(ideal, true).reshape(2, kHeight);
  for (cv::Mat* img : {&view.left, &view.right}) {
    cv::Mat raw;
    cv::remap(*img, raw, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 128);
    *img = raw;
  }
  const auto r = SelfCalibrateStereo(cam, cam, {view});
  EXPECT_LT(RotationAngleDeg(r.model.T_cam0_cam1.linear(), truth.linear()), 0.2);
  EXPECT_LT(DirectionAngleDeg(r.model.T_cam0_cam1.translation(), truth.translation()), 1.0);
}

TEST(StereoSelfCalibration, RejectsAResultTooFarFromThePrior) {
  const auto truth = TrueExtrinsics();
  const StereoView view = RenderView(testing::MakeDepthScene(51), truth, Perturbed(truth, 2.0));
  StereoSelfCalibrationParams params;
  params.prior_gate_px = 40;  // let the matches through, then judge the result
  params.max_rotation_deviation_deg = 0.5;
  std::string why;
  EXPECT_EQ(CodeOf([&] { SelfCalibrateStereo(Camera(), Camera(), {view}, params); }, &why),
            ErrorCode::kRejectedByPrior);
  EXPECT_NE(why.find("kinematic prior"), std::string::npos) << why;
}

TEST(StereoSelfCalibration, MultiFrameAccumulatesMatchesOfOneEyeConfiguration) {
  const auto truth = TrueExtrinsics();
  const auto prior = Perturbed(truth, 1.0);
  const StereoView a = RenderView(testing::MakeDepthScene(61), truth, prior);
  const StereoView b = RenderView(testing::MakeDepthScene(62), truth, prior);
  const CameraIntrinsics cam = Camera();
  const auto single = SelfCalibrateStereo(cam, cam, {a});
  const auto both = SelfCalibrateStereo(cam, cam, {a, b});
  EXPECT_GT(both.model.inliers, single.model.inliers + 50);
  EXPECT_LT(RotationAngleDeg(both.model.T_cam0_cam1.linear(), truth.linear()), 0.2);
  // Frames from another vergence must not be mixed in.
  StereoView c = b;
  c.T_cam0_cam1_prior = Perturbed(prior, 1.0);
  std::string why;
  EXPECT_EQ(CodeOf([&] { SelfCalibrateStereo(cam, cam, {a, c}); }, &why), ErrorCode::kInvalidInput);
  EXPECT_NE(why.find("vergence"), std::string::npos) << why;
}

TEST(StereoSelfCalibration, BaselineDirectionPriorPullsTowardsTheKinematics) {
  const auto truth = TrueExtrinsics();
  Eigen::Isometry3d prior = truth;
  prior.translation() = Eigen::AngleAxisd(2.0 * M_PI / 180, Eigen::Vector3d::UnitY()) *
                        truth.translation();  // the prior's baseline is 2 deg off
  const StereoView view = RenderView(testing::MakeDepthScene(81), truth, prior);
  const CameraIntrinsics cam = Camera();
  const auto data_only = SelfCalibrateStereo(cam, cam, {view});
  EXPECT_LT(DirectionAngleDeg(data_only.model.T_cam0_cam1.translation(), truth.translation()), 1.0);
  StereoSelfCalibrationParams params;
  params.baseline_direction_prior_sigma_deg = 0.01;  // trust the kinematics almost fully
  const auto pulled = SelfCalibrateStereo(cam, cam, {view}, params);
  EXPECT_LT(DirectionAngleDeg(pulled.model.T_cam0_cam1.translation(), prior.translation()), 0.2);
}

TEST(StereoSelfCalibration, CancelledByTheProgressCallback) {
  const auto truth = TrueExtrinsics();
  const StereoView view = RenderView(testing::MakeDepthScene(71), truth, truth);
  const CameraIntrinsics cam = Camera();
  EXPECT_EQ(CodeOf([&] {
              SelfCalibrateStereo(cam, cam, {view}, {},
                                  [](const Progress& p) { return p.stage != "ransac"; });
            }),
            ErrorCode::kCancelled);
}

}  // namespace
}  // namespace epmap::calibration
