#include <gtest/gtest.h>

#include "perception/kinematics/urdf_chain.h"

namespace epmap {
namespace {

constexpr const char* kTwoJointUrdf = R"(<?xml version="1.0"?>
<robot name="pan_tilt">
  <link name="base"/>
  <link name="pan_link"/>
  <link name="tilt_link"/>
  <link name="cam0_optical"/>
  <joint name="pan" type="revolute">
    <parent link="base"/><child link="pan_link"/>
    <origin xyz="0 0 0.5" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <joint name="tilt" type="revolute">
    <parent link="pan_link"/><child link="tilt_link"/>
    <origin xyz="0.1 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="optical" type="fixed">
    <parent link="tilt_link"/><child link="cam0_optical"/>
    <origin xyz="0 0 0" rpy="-1.5707963267948966 0 -1.5707963267948966"/>
  </joint>
</robot>)";

TEST(UrdfChain, ForwardKinematicsOfAPanTilt) {
  auto chain = kinematics::UrdfChain::FromString(kTwoJointUrdf);
  EXPECT_EQ(chain.root_link(), "base");
  EXPECT_EQ(chain.joint_names(), (std::vector<std::string>{"pan", "tilt"}));
  // Joint values come in another order and with an extra joint: bind by name.
  chain.BindJointOrder({"tilt", "other", "pan"});
  const double pan = 0.5;
  const Eigen::Isometry3d T = chain.Cam0Pose({0.0, 9.0, pan});
  EXPECT_NEAR(T.translation().x(), 0.1 * std::cos(pan), 1e-12);
  EXPECT_NEAR(T.translation().y(), 0.1 * std::sin(pan), 1e-12);
  EXPECT_NEAR(T.translation().z(), 0.5, 1e-12);
  // Optical z (forward) points along the pan direction.
  const Eigen::Vector3d z = T.linear().col(2);
  EXPECT_NEAR(z.x(), std::cos(pan), 1e-9);
  EXPECT_NEAR(z.y(), std::sin(pan), 1e-9);
}

TEST(UrdfChain, ClearErrors) {
  EXPECT_THROW(kinematics::UrdfChain::FromString("<robot"), std::runtime_error);
  std::string no_cam = kTwoJointUrdf;
  no_cam.replace(no_cam.find("cam0_optical"), 12, "cam9_optical");
  no_cam.replace(no_cam.find("cam0_optical"), 12, "cam9_optical");
  EXPECT_THROW(kinematics::UrdfChain::FromString(no_cam), std::runtime_error);
  auto chain = kinematics::UrdfChain::FromString(kTwoJointUrdf);
  EXPECT_THROW(chain.BindJointOrder({"pan"}), std::invalid_argument);
  EXPECT_THROW(chain.Cam0Pose({0.1}), std::invalid_argument);
  EXPECT_THROW(chain.Cam0Pose({0.1, std::nan("")}), std::invalid_argument);
}

// kTwoJointUrdf with every occurrence of `from` renamed `to`.
std::string Renamed(std::string urdf, const std::string& from, const std::string& to) {
  for (size_t p; (p = urdf.find(from)) != std::string::npos;) urdf.replace(p, from.size(), to);
  return urdf;
}

TEST(UrdfChain, ARobotsOwnCameraLinkNames) {
  // A robot's URDF names its optical frames its own way: the same chain under other names.
  const std::string urdf = Renamed(kTwoJointUrdf, "cam0_optical", "left_camera_optical_frame");
  const kinematics::CameraLinks links{"left_camera_optical_frame", "right_camera_optical_frame"};
  const auto named = kinematics::UrdfChain::FromString(urdf, links);
  const auto reference = kinematics::UrdfChain::FromString(kTwoJointUrdf);
  EXPECT_EQ(named.camera_links().left, "left_camera_optical_frame");
  EXPECT_EQ(named.joint_names(), reference.joint_names());
  EXPECT_FALSE(named.has_cam1());
  EXPECT_TRUE(named.Cam0Pose({0.3, -0.2}).isApprox(reference.Cam0Pose({0.3, -0.2}), 1e-12));
  try {
    named.Cam1Pose({0.3, -0.2});
    ADD_FAILURE() << "no right camera link, yet a pose";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("right_camera_optical_frame"), std::string::npos)
        << e.what();
  }
  // Under the default names that URDF has no camera: the error names the link it looked for
  // and the links that look like optical frames.
  try {
    kinematics::UrdfChain::FromString(urdf);
    ADD_FAILURE() << "loaded without a cam0_optical link";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'cam0_optical'"), std::string::npos) << what;
    EXPECT_NE(what.find("left_camera_optical_frame"), std::string::npos) << what;
  }
}

TEST(UrdfChain, LinksBelowTheRootAndTheirPoses) {
  // rt/odom may move another link than the root: the pipeline asks whether the URDF has it and
  // where it is; a link behind a joint no camera chain reads has no known pose.
  std::string urdf = kTwoJointUrdf;
  urdf.replace(urdf.find("</robot>"), 8, R"(
  <link name="wheel"/>
  <joint name="wheel_joint" type="continuous">
    <parent link="base"/><child link="wheel"/>
    <origin xyz="0 0.2 0.05" rpy="0 0 0"/><axis xyz="0 1 0"/>
  </joint>
  <link name="imu_link"/>
  <joint name="imu_joint" type="fixed">
    <parent link="base"/><child link="imu_link"/>
    <origin xyz="0.1 0 0.2" rpy="0 0 0"/>
  </joint>
</robot>)");
  const auto chain = kinematics::UrdfChain::FromString(urdf);
  EXPECT_TRUE(chain.HasLink("base"));
  EXPECT_TRUE(chain.HasLink("tilt_link"));
  EXPECT_TRUE(chain.HasLink("wheel"));
  EXPECT_FALSE(chain.HasLink("base_footprint"));
  const Eigen::Isometry3d T_base_pan = chain.LinkPose("pan_link", {0.4, 0.0});
  EXPECT_TRUE(T_base_pan.translation().isApprox(Eigen::Vector3d(0, 0, 0.5)));
  EXPECT_NEAR(Eigen::AngleAxisd(T_base_pan.linear()).angle(), 0.4, 1e-12);
  EXPECT_THROW(chain.LinkPose("wheel", {0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(chain.LinkPose("base_footprint", {0.0, 0.0}), std::invalid_argument);
  // Only fixed joints from the root: the frames odometry may move without a joint reading.
  EXPECT_EQ(chain.LinksFixedToRoot(), (std::vector<std::string>{"base", "imu_link"}));
  EXPECT_TRUE(
      chain.LinkPose("imu_link", {0.3, 0.1}).translation().isApprox(Eigen::Vector3d(0.1, 0, 0.2)));
}

}  // namespace
}  // namespace epmap
