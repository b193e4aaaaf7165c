#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>

#include "clients/sim/scenario.h"
#include "perception/kinematics/urdf_chain.h"
#include "tests/unit/sim/warp_check.h"

namespace epmap::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

ScenarioOptions Small(const std::string& name, bool noise = true) {
  ScenarioOptions o;
  o.name = name;
  o.width = 320;
  o.height = 240;
  o.noise = noise;
  return o;
}

double RotationAngle(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

TEST(HeadScenario, RightImageWarpedByTrueDisparityReproducesLeft) {
  const Scenario* s = &testing::Shared(Small("head"));
  ASSERT_TRUE(s->rectified());
  for (int index : {0, 41, 170}) {
    const SimFrame f = s->Render(index);
    ASSERT_EQ(f.left.type(), CV_8UC3);
    // Rectified: the true disparity is fx * B / z and the matching right pixel is x - d on the
    // same row.
    const double B = f.gt_T_cam0_cam1.translation().x();
    EXPECT_NEAR(B, 0.068, 1e-12);
    EXPECT_LT(f.gt_T_cam0_cam1.translation().tail<2>().norm(), 1e-12);
    EXPECT_LT(Eigen::AngleAxisd(f.gt_T_cam0_cam1.linear()).angle(), 1e-12);
    const auto cam = s->cam0();
    for (int y = 0; y < f.left.rows; y += 7) {
      for (int x = 0; x < f.left.cols; x += 7) {
        const float z = f.gt_depth.at<float>(y, x), d = f.gt_disparity.at<float>(y, x);
        ASSERT_TRUE(std::isfinite(z));  // a closed room: every pixel sees a surface
        EXPECT_NEAR(d, cam.fu * B / z, 1e-3);
      }
    }
    // Noise of 2 grey levels in each image: 10 levels is > 3.5 sigma of their difference.
    const auto stats = testing::WarpRightIntoLeft(f, cam, 10.0);
    EXPECT_GT(stats.visible, 0.7 * f.left.total()) << "frame " << index;
    EXPECT_GE(stats.consistent_share(), 0.95) << "frame " << index;
  }
}

TEST(HeadScenario, WithoutNoiseTheWarpIsTighter) {
  const Scenario* s = &testing::Shared(Small("head", false));
  const SimFrame f = s->Render(100);
  const auto stats = testing::WarpRightIntoLeft(f, s->cam0(), 3.0);
  EXPECT_GE(stats.consistent_share(), 0.95);
}

TEST(HeadScenario, UrdfThroughKdlGivesTheRenderedCameraPoses) {
  // --no-noise: encoder readings are the true joints and the true chain is the shipped URDF.
  {
    const Scenario* s = &testing::Shared(Small("head", false));
    auto chain = kinematics::UrdfChain::FromString(s->urdf());
    chain.BindJointOrder(s->joint_names());
    for (int index : {0, 77, 299}) {
      const SimFrame f = s->Render(index);
      EXPECT_EQ(f.joints, f.gt_joints);
      const Eigen::Isometry3d T0 = chain.Cam0Pose(f.joints), T1 = chain.Cam1Pose(f.joints);
      EXPECT_LT((T0.matrix() - f.gt_T_world_cam0.matrix()).cwiseAbs().maxCoeff(), 1e-9);
      EXPECT_LT((T1.matrix() - f.gt_T_world_cam1.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    }
  }
  // With noise: the true joints through the true chain give the rendered poses exactly; the
  // encoder readings through the shipped URDF are off by the unmodelled offsets and noise.
  const Scenario* s = &testing::Shared(Small("head"));
  EXPECT_NE(s->true_urdf(), s->urdf());
  auto truth = kinematics::UrdfChain::FromString(s->true_urdf());
  auto nominal = kinematics::UrdfChain::FromString(s->urdf());
  truth.BindJointOrder(s->joint_names());
  nominal.BindJointOrder(s->joint_names());
  double max_dp = 0, max_dr = 0;
  for (int index : {0, 77, 299}) {
    const SimFrame f = s->Render(index);
    EXPECT_LT(
        (truth.Cam0Pose(f.gt_joints).matrix() - f.gt_T_world_cam0.matrix()).cwiseAbs().maxCoeff(),
        1e-9);
    const Eigen::Isometry3d T = nominal.Cam0Pose(f.joints);
    max_dp = std::max(max_dp, (T.translation() - f.gt_T_world_cam0.translation()).norm());
    max_dr = std::max(max_dr, RotationAngle(T, f.gt_T_world_cam0));
  }
  EXPECT_GT(max_dp, 1e-5);  // there is an offset ...
  EXPECT_LT(max_dp, 2e-3);  // ... of about a millimetre at most
  EXPECT_GT(max_dr, 0.005 * kDeg);
  EXPECT_LT(max_dr, 0.2 * kDeg);
}

TEST(HeadScenario, NeckMovesSmoothlyEyesStayParallelEncodersAreQuantised) {
  const Scenario* s = &testing::Shared(Small("head"));
  EXPECT_EQ(s->frame_count(), 300);
  EXPECT_DOUBLE_EQ(s->rate_hz(), 30.0);
  EXPECT_EQ(s->joint_names(),
            (std::vector<std::string>{"neck_pitch", "neck_roll", "neck_yaw", "eyes_tilt",
                                      "left_eye_pan", "right_eye_pan"}));
  std::vector<double> previous;
  double max_step = 0, max_yaw = 0;
  for (int i = 0; i < 300; i += 3) {
    const SimFrame f = s->Render(i);
    EXPECT_EQ(f.stamp_ns, kRecordStartStampNs + std::llround(i * 1e9 / 30));
    ASSERT_EQ(f.gt_joints.size(), 6u);
    EXPECT_EQ(f.gt_joints[3], 0.0);
    EXPECT_EQ(f.gt_joints[4], 0.0);
    EXPECT_EQ(f.gt_joints[5], 0.0);
    for (int j = 0; j < 6; ++j) {
      const double steps = f.joints[j] / (0.01 * kDeg);
      EXPECT_NEAR(steps, std::round(steps), 1e-6);  // 0.01 degree encoder steps
      EXPECT_LT(std::abs(f.joints[j] - f.gt_joints[j]), 0.12 * kDeg);
    }
    max_yaw = std::max(max_yaw, std::abs(f.gt_joints[2]));
    if (!previous.empty()) {
      for (int j = 0; j < 3; ++j)
        max_step = std::max(max_step, std::abs(f.gt_joints[j] - previous[j]) / 3);
    }
    previous = f.gt_joints;
  }
  EXPECT_LT(max_step, 3 * kDeg);  // a few degrees per frame at most
  EXPECT_GT(max_yaw, 5 * kDeg);   // ... and it does move
  EXPECT_LT(max_yaw, 20 * kDeg);
}

TEST(HeadScenario, ToyIsSeenInAboutHalfTheFramesAndCoversUnderTenPercent) {
  ScenarioOptions o = Small("head");
  o.width = 160;
  o.height = 120;
  const Scenario* s = &testing::Shared(o);
  int seen = 0, frames = 0;
  double max_cover = 0;
  for (int i = 0; i < s->frame_count(); i += 2, ++frames) {
    const SimFrame f = s->Render(i);
    const double cover = cv::countNonZero(f.gt_unexpected) / double(f.gt_unexpected.total());
    max_cover = std::max(max_cover, cover);
    seen += cover > 0;
  }
  const double share = double(seen) / frames;
  EXPECT_GT(share, 0.35);
  EXPECT_LT(share, 0.65);
  EXPECT_LT(max_cover, 0.10);
  EXPECT_GT(max_cover, 0.01);
}

TEST(HeadScenario, DisparityRangeCoversTheScene) {
  const Scenario* s = &testing::Shared(Small("head"));
  for (int i = 0; i < 300; i += 37) {
    const SimFrame f = s->Render(i);
    double lo, hi;
    cv::minMaxLoc(f.gt_disparity, &lo, &hi);
    EXPECT_LT(hi, s->num_disparities()) << "frame " << i;
    EXPECT_GT(lo, 0.0);
  }
}

TEST(HeadScenario, SensorsOnlyFrameHasTheSameImagesWithoutGroundTruth) {
  const Scenario* s = &testing::Shared(Small("head"));
  const SimFrame full = s->Render(60), sensors = s->RenderSensors(60);
  EXPECT_EQ(cv::norm(full.left, sensors.left, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(full.right, sensors.right, cv::NORM_INF), 0);
  EXPECT_EQ(full.joints, sensors.joints);
  EXPECT_EQ(full.stamp_ns, sensors.stamp_ns);
  EXPECT_TRUE(sensors.gt_disparity.empty());
  EXPECT_TRUE(sensors.gt_depth.empty());
  EXPECT_TRUE(sensors.gt_unexpected.empty());
  EXPECT_TRUE(full.gt_T_world_cam0.isApprox(sensors.gt_T_world_cam0, 0));
}

TEST(HeadScenario, RenderIsDeterministicAndIndependentOfOrder) {
  const auto a = MakeScenario(Small("head"));  // two separate instances
  const auto b = MakeScenario(Small("head"));
  const SimFrame late = b->Render(120);
  b->Render(3);
  const SimFrame f1 = a->Render(120), f2 = b->Render(120);
  EXPECT_EQ(cv::norm(f1.left, f2.left, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(f1.right, late.right, cv::NORM_INF), 0);
  EXPECT_EQ(f1.joints, f2.joints);
  ScenarioOptions other = Small("head");
  other.seed = 2;
  const SimFrame f3 = MakeScenario(other)->Render(120);
  EXPECT_GT(cv::norm(f1.left, f3.left, cv::NORM_L1), 0);
}

}  // namespace
}  // namespace epmap::sim
