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

}  // namespace
}  // namespace epmap
