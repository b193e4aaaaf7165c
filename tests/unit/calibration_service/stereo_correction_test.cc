// The stereo correction model (T_prior^-1 T_estimated, combined by the median), its JSON, the
// active-model holder, and the pipeline's rectification under a stereo model (maps rebuilt only
// when the extrinsics move noticeably).

#include <gtest/gtest.h>

#include "perception/calibration/stereo_self_calibration.h"
#include "services/mapping/calibration/active_models.h"
#include "services/mapping/calibration/model_rectification.h"
#include "services/mapping/calibration/stereo_correction.h"

namespace epmap::mapping {
namespace {

Eigen::Isometry3d Pose(double rx, double ry, double rz, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

constexpr double kDeg = M_PI / 180.0;

TEST(StereoCorrection, CorrectionAppliedToItsPriorGivesTheEstimate) {
  const auto prior = Pose(0.01, 0.08, -0.02, Eigen::Vector3d(0.068, 0.001, -0.002));
  const auto estimate = Pose(0.012, 0.093, -0.019, Eigen::Vector3d(0.0679, 0.0015, -0.0021));
  StereoCorrectionModel m;
  m.correction = CorrectionOf(prior, estimate);
  EXPECT_TRUE(m.Apply(prior).isApprox(estimate, 1e-12));
}

TEST(StereoCorrection, MedianIgnoresAnOddFrame) {
  // Five frames agree on a 0.75 deg correction about y within 0.02 deg; one is 2 deg off.
  std::vector<Eigen::Isometry3d> c;
  for (double e : {-0.02, -0.01, 0.0, 0.01, 0.02}) {
    c.push_back(Pose(0, (0.75 + e) * kDeg, 0, Eigen::Vector3d(0.0004, 0, 0.0001 * e)));
  }
  c.push_back(Pose(0.5 * kDeg, 2.75 * kDeg, 0, Eigen::Vector3d(0.003, 0.002, 0)));
  const auto median = MedianCorrection(c);
  EXPECT_NEAR(RotationDifferenceDeg(median, Pose(0, 0.75 * kDeg, 0, Eigen::Vector3d::Zero())), 0,
              0.011);
  EXPECT_NEAR(median.translation().x(), 0.0004, 1e-9);
  EXPECT_THROW(MedianCorrection({}), std::invalid_argument);
}

TEST(StereoCorrection, JsonRoundTripsAndRefusesGarbage) {
  StereoCorrectionModel m;
  m.correction = Pose(0.001, 0.013, 0.0005, Eigen::Vector3d(0.0004, -0.0001, 0.00002));
  m.T_cam0_cam1_reference = Pose(0, 0.08, 0, Eigen::Vector3d(0.068, 0, 0.003));
  m.frames_used = 9;
  m.frames_failed = 1;
  m.spread_deg = 0.02;
  m.median_vertical_offset_px = 0.11;
  m.prior_median_vertical_offset_px = 0.29;
  m.inliers = 1234;
  const auto back = StereoCorrectionModel::FromJson(m.ToJson());
  EXPECT_TRUE(back.correction.isApprox(m.correction, 1e-15));
  EXPECT_TRUE(back.T_cam0_cam1_reference.isApprox(m.T_cam0_cam1_reference, 1e-15));
  EXPECT_EQ(back.frames_used, 9);
  EXPECT_EQ(back.inliers, 1234);
  EXPECT_DOUBLE_EQ(back.prior_median_vertical_offset_px, 0.29);
  EXPECT_THROW(StereoCorrectionModel::FromJson("{}"), std::invalid_argument);
  EXPECT_THROW(StereoCorrectionModel::FromJson("not json"), std::invalid_argument);
  std::string bad = m.ToJson();
  bad.replace(bad.find("\"q_wxyz\":[") + 10, 1, "7");  // not a unit quaternion
  EXPECT_THROW(StereoCorrectionModel::FromJson(bad), std::invalid_argument);
}

TEST(ActiveModels, CorrectVisionPointIsTheIdentityWithoutAModel) {
  ActiveModels active;
  const Eigen::Vector3d x(0.3, -0.1, -0.2);
  EXPECT_EQ(active.CorrectVisionPoint(x), x);
  EXPECT_EQ(active.eye_hand_id(), "");
  calibration::LinearExpert shift;
  shift.translation = Eigen::Vector3d(0.01, 0.02, -0.03);
  active.SetEyeHand(std::make_shared<const ActiveModels::EyeHand>(ActiveModels::EyeHand{
      "eye-hand-7", calibration::EyeHandModel(calibration::EyeHandMethod::kSe3, {shift})}));
  EXPECT_TRUE(active.CorrectVisionPoint(x).isApprox(x + shift.translation));
  EXPECT_EQ(active.eye_hand_id(), "eye-hand-7");
  // A reader keeps the model it took even when it is swapped out.
  const auto held = active.eye_hand();
  active.SetEyeHand(nullptr);
  EXPECT_EQ(active.CorrectVisionPoint(x), x);
  EXPECT_EQ(held->id, "eye-hand-7");
}

dds::CameraCalibration Camera() {
  return camera::Pinhole({320, 240, 277, 277, 160, 120});
}

TEST(ModelRectification, RebuildsOnlyWhenTheExtrinsicsMoveNoticeably) {
  ActiveModels::Stereo model{"stereo-extrinsics-1", {}};
  model.model.correction = Pose(0, 0.75 * kDeg, 0, Eigen::Vector3d(0.0004, 0, 0));
  SensorState::CameraInfos infos;
  infos.left = Camera();
  infos.right = Camera();
  infos.version = 3;
  ModelRectification rect(0.01);
  std::string reason;
  const auto prior = Pose(0, -4 * kDeg, 0, Eigen::Vector3d(0.068, 0, 0.0024));
  const auto* r = rect.For(model, infos, prior, &reason);
  ASSERT_NE(r, nullptr) << reason;
  EXPECT_EQ(rect.rebuilds(), 1u);
  EXPECT_TRUE(rect.built_for()->isApprox(model.model.Apply(prior)));
  EXPECT_NEAR(r->geometry().baseline_m, 0.068, 1e-3);
  // The eyes moved by 0.005 deg: the maps are still good.
  rect.For(model, infos, prior * Pose(0, 0.005 * kDeg, 0, Eigen::Vector3d::Zero()), &reason);
  EXPECT_EQ(rect.rebuilds(), 1u);
  // By 0.5 deg: new maps.
  rect.For(model, infos, prior * Pose(0, 0.5 * kDeg, 0, Eigen::Vector3d::Zero()), &reason);
  EXPECT_EQ(rect.rebuilds(), 2u);
  // Same extrinsics, new CameraInfo or a new model: new maps.
  infos.version = 4;
  rect.For(model, infos, prior * Pose(0, 0.5 * kDeg, 0, Eigen::Vector3d::Zero()), &reason);
  EXPECT_EQ(rect.rebuilds(), 3u);
  model.id = "stereo-extrinsics-2";
  rect.For(model, infos, prior * Pose(0, 0.5 * kDeg, 0, Eigen::Vector3d::Zero()), &reason);
  EXPECT_EQ(rect.rebuilds(), 4u);
  // Without CameraInfo there is no K: refused with a reason.
  SensorState::CameraInfos none;
  EXPECT_EQ(rect.For(model, none, prior, &reason), nullptr);
  EXPECT_EQ(reason, "no_camera_info");
}

}  // namespace
}  // namespace epmap::mapping
