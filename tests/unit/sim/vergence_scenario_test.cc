#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

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
