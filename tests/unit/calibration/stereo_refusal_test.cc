// Stereo self-calibration refuses what it cannot calibrate from, before or after the features:
// a planar scene, a featureless scene, bad images or priors; and models round-trip as JSON.

#include <gtest/gtest.h>

#include "perception/calibration/stereo_self_calibration.h"
#include "tests/unit/calibration/stereo_test_rig.h"

namespace epmap::calibration {
namespace {

using namespace testing;

TEST(StereoSelfCalibration, RefusesAPlanarScene) {
  const auto truth = TrueExtrinsics();
  const StereoView view = RenderView(testing::MakePlanarScene(41), truth, Perturbed(truth, 0.5));
  std::string why;
  EXPECT_EQ(CodeOf([&] { SelfCalibrateStereo(Camera(), Camera(), {view}); }, &why),
            ErrorCode::kPlanarScene);
  EXPECT_NE(why.find("planar"), std::string::npos) << why;
}

TEST(StereoSelfCalibration, RefusesAFeaturelessScene) {
  StereoView view;
  view.left = cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(120));
  view.right = view.left.clone();
  cv::circle(view.left, {200, 200}, 30, cv::Scalar(200), cv::FILLED);  // a lone blob
  view.T_cam0_cam1_prior = TrueExtrinsics();
  std::string why;
  EXPECT_EQ(CodeOf([&] { SelfCalibrateStereo(Camera(), Camera(), {view}); }, &why),
            ErrorCode::kInsufficientFeatures);
  EXPECT_NE(why.find("textured"), std::string::npos) << why;
}

TEST(StereoSelfCalibration, RefusesBadInput) {
  const CameraIntrinsics cam = Camera();
  StereoView v;
  v.T_cam0_cam1_prior = TrueExtrinsics();
  EXPECT_EQ(CodeOf([&] { SelfCalibrateStereo(cam, cam, {}); }), ErrorCode::kInvalidInput);
  EXPECT_EQ(CodeOf([&] { SelfCalibrateStereo(cam, cam, {v}); }), ErrorCode::kInvalidInput);
  v.left = cv::Mat(100, 100, CV_8UC1, cv::Scalar(0));
  v.right = v.left.clone();
  EXPECT_EQ(CodeOf([&] { SelfCalibrateStereo(cam, cam, {v}); }), ErrorCode::kInvalidInput);
  v.left = cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(0));
  v.right = v.left.clone();
  v.T_cam0_cam1_prior = Eigen::Isometry3d::Identity();  // no baseline
  EXPECT_EQ(CodeOf([&] { SelfCalibrateStereo(cam, cam, {v}); }), ErrorCode::kInvalidInput);
}

TEST(StereoExtrinsicsModel, JsonRoundTrip) {
  StereoExtrinsicsModel m;
  m.T_cam0_cam1 = TrueExtrinsics();
  m.rotation_deviation_deg = 0.7;
  m.inliers = 321;
  const auto back = StereoExtrinsicsModel::FromJson(m.ToJson());
  EXPECT_LT((back.T_cam0_cam1.matrix() - m.T_cam0_cam1.matrix()).norm(), 1e-15);
  EXPECT_EQ(back.inliers, 321);
  EXPECT_DOUBLE_EQ(back.rotation_deviation_deg, 0.7);
  EXPECT_THROW(StereoExtrinsicsModel::FromJson("{\"type\":\"eye-hand\"}"), CalibrationError);
}

}  // namespace
}  // namespace epmap::calibration
