// Sec. III-A end to end on rendered textured scenes: SIFT -> F_K gate -> 8-point RANSAC -> E ->
// chirality -> acceptance near the prior -> rectification; and the refusals (planar scene,
// featureless scene, prior too far, frames with different eye configurations, bad images).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

#include "perception/calibration/stereo_self_calibration.h"
#include "tests/unit/calibration/synthetic_stereo.h"

namespace epmap::calibration {
namespace {

constexpr int kWidth = 560, kHeight = 420;

CameraIntrinsics Camera() {
  CameraIntrinsics c;
  c.width = kWidth;
  c.height = kHeight;
  c.k << 440, 0, 283, 0, 440, 207, 0, 0, 1;
  return c;
}

Eigen::Isometry3d TrueExtrinsics() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translate(Eigen::Vector3d(0.068, 0.0015, -0.001));
  t.rotate(Eigen::AngleAxisd(-0.07, Eigen::Vector3d::UnitY()) *
           Eigen::AngleAxisd(0.004, Eigen::Vector3d::UnitX()));
  return t;
}

// The prior the kinematics would give with biased eye encoders: the truth rotated a bit.
Eigen::Isometry3d Perturbed(const Eigen::Isometry3d& t, double degrees) {
  Eigen::Isometry3d p = t;
  p.rotate(Eigen::AngleAxisd(degrees * M_PI / 180, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()));
  return p;
}

StereoView RenderView(const std::vector<testing::TexturedQuad>& scene,
                      const Eigen::Isometry3d& truth, const Eigen::Isometry3d& prior) {
  const CameraIntrinsics c = Camera();
  StereoView v;
  v.left = testing::Render(scene, c.k, Eigen::Isometry3d::Identity(), {kWidth, kHeight});
  v.right = testing::Render(scene, c.k, truth, {kWidth, kHeight});
  v.T_cam0_cam1_prior = prior;
  return v;
}

ErrorCode CodeOf(const std::function<void()>& f, std::string* message = nullptr) {
  try {
    f();
  } catch (const CalibrationError& e) {
    if (message) *message = e.what();
    return e.code();
  }
  ADD_FAILURE() << "no CalibrationError thrown";
  return ErrorCode::kNotConverged;
}

// Median |dy| of SIFT matches between two rectified images.
double MedianVerticalOffset(const cv::Mat& l, const cv::Mat& r) {
  std::vector<Eigen::Vector2d> pl, pr;
  MatchSift(l, r, 2000, 0.7, true, &pl, &pr);
  std::vector<double> dy;
  for (size_t i = 0; i < pl.size(); ++i) dy.push_back(std::abs(pl[i].y() - pr[i].y()));
  if (dy.empty()) return 1e9;
  std::nth_element(dy.begin(), dy.begin() + static_cast<std::ptrdiff_t>(dy.size() / 2), dy.end());
  return dy[dy.size() / 2];
}

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
