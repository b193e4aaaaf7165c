#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <opencv2/features2d.hpp>

#include "clients/sim/scenario.h"
#include "perception/kinematics/urdf_chain.h"
#include "tests/unit/sim/warp_check.h"

namespace epmap::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

ScenarioOptions Small(bool noise = true) {
  ScenarioOptions o;
  o.name = "vergence";
  o.width = 320;
  o.height = 240;
  o.noise = noise;
  return o;
}

TEST(VergenceScenario, RightImageWarpedThroughTrueGeometryReproducesLeft) {
  const Scenario* s = &testing::Shared(Small());
  EXPECT_FALSE(s->rectified());
  for (int index : {0, 95, 260}) {
    const SimFrame f = s->Render(index);
    EXPECT_TRUE(f.gt_disparity.empty());  // unrectified: no disparity ground truth
    const auto stats = testing::WarpRightIntoLeft(f, s->cam0(), 10.0);
    EXPECT_GT(stats.visible, 0.6 * f.left.total()) << "frame " << index;
    EXPECT_GE(stats.consistent_share(), 0.95) << "frame " << index;
  }
}

TEST(VergenceScenario, EyesVergeAndTiltAndTheExtrinsicsChange) {
  const Scenario* s = &testing::Shared(Small());
  auto truth = kinematics::UrdfChain::FromString(s->true_urdf());
  truth.BindJointOrder(s->joint_names());
  double min_v = 1e9, max_v = -1e9, min_tilt = 1e9, max_tilt = -1e9;
  double bias_sum = 0;
  int n = 0;
  for (int i = 0; i < s->frame_count(); i += 10, ++n) {
    const SimFrame f = s->Render(i);
    const double vergence = f.gt_joints[4] - f.gt_joints[5];
    min_v = std::min(min_v, vergence);
    max_v = std::max(max_v, vergence);
    min_tilt = std::min(min_tilt, f.gt_joints[3]);
    max_tilt = std::max(max_tilt, f.gt_joints[3]);
    // The relative rotation of the two cameras is the vergence (eyes turn about parallel axes).
    EXPECT_NEAR(Eigen::AngleAxisd(f.gt_T_cam0_cam1.linear()).angle(), std::abs(vergence), 1e-3);
    EXPECT_NEAR(f.gt_T_cam0_cam1.translation().norm(), 0.068, 1e-3);
    // Ground-truth extrinsics are those of the true chain at the true joints.
    const Eigen::Isometry3d T01 =
        truth.Cam0Pose(f.gt_joints).inverse() * truth.Cam1Pose(f.gt_joints);
    EXPECT_LT((T01.matrix() - f.gt_T_cam0_cam1.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    bias_sum += (f.joints[4] - f.joints[5]) - vergence;
  }
  EXPECT_GT(min_v, 1.5 * kDeg);
  EXPECT_LT(max_v, 7.5 * kDeg);
  EXPECT_GT(max_v - min_v, 1.5 * kDeg);
  EXPECT_GT(max_tilt - min_tilt, 2 * kDeg);
  // The encoders' vergence is biased by 0.75 degrees.
  EXPECT_NEAR(bias_sum / n, 0.75 * kDeg, 0.02 * kDeg);
}

TEST(VergenceScenario, EnoughSiftMatchesOverDepthForSelfCalibration) {
  // Paper 001, Sec. III-A matches SIFT features between the eyes: the room must offer many,
  // spread over depth, that agree with the true epipolar geometry.
  const Scenario* s = &testing::Shared(Small());
  const auto sift = cv::SIFT::create();
  const auto cam = s->cam0();
  Eigen::Matrix3d K;
  K << cam.fu, 0, cam.cu, 0, cam.fv, cam.cv, 0, 0, 1;
  for (int index : {30, 210}) {
    const SimFrame f = s->Render(index);
    std::vector<cv::KeyPoint> k0, k1;
    cv::Mat d0, d1;
    sift->detectAndCompute(f.left, cv::noArray(), k0, d0);
    sift->detectAndCompute(f.right, cv::noArray(), k1, d1);
    std::vector<std::vector<cv::DMatch>> knn;
    cv::BFMatcher().knnMatch(d0, d1, knn, 2);
    // F = K^-T [t]x R K^-1 with (R, t) = T_cam1_cam0.
    const Eigen::Isometry3d T10 = f.gt_T_cam0_cam1.inverse();
    const Eigen::Vector3d t = T10.translation();
    Eigen::Matrix3d tx;
    tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
    const Eigen::Matrix3d F = K.inverse().transpose() * tx * T10.linear() * K.inverse();
    int consistent = 0;
    float near = 1e9F, far = 0;
    for (const auto& m : knn) {
      if (m.size() < 2 || m[0].distance > 0.8F * m[1].distance) continue;
      const cv::Point2f a = k0[static_cast<size_t>(m[0].queryIdx)].pt;
      const cv::Point2f b = k1[static_cast<size_t>(m[0].trainIdx)].pt;
      const Eigen::Vector3d line = F * Eigen::Vector3d(a.x, a.y, 1);
      if (std::abs(line.dot(Eigen::Vector3d(b.x, b.y, 1))) / line.head<2>().norm() > 1.0) continue;
      ++consistent;
      const float z = f.gt_depth.at<float>(cvRound(a.y), cvRound(a.x));
      near = std::min(near, z);
      far = std::max(far, z);
    }
    EXPECT_GE(consistent, 80) << "frame " << index;
    EXPECT_GT(far - near, 1.0F) << "frame " << index;
  }
}

TEST(VergenceScenario, WithoutNoiseEncodersAreExact) {
  const Scenario* s = &testing::Shared(Small(false));
  const SimFrame f = s->Render(50);
  EXPECT_EQ(f.joints, f.gt_joints);
  auto chain = kinematics::UrdfChain::FromString(s->urdf());
  chain.BindJointOrder(s->joint_names());
  EXPECT_LT((chain.Cam1Pose(f.joints).matrix() - f.gt_T_world_cam1.matrix()).cwiseAbs().maxCoeff(),
            1e-9);
}

}  // namespace
}  // namespace epmap::sim
