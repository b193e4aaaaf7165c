#pragma once
// A small iCub-like head for tests: neck pitch/roll/yaw, a common eye tilt and two eye pans, the
// eyes 68 mm apart, optical frames x right, y down, z forward. Written for these tests (the
// simulator's own URDF is another file).

namespace epmap::testing {

inline constexpr const char* kHeadUrdf = R"(<?xml version="1.0"?>
<robot name="test_head">
  <link name="base"/>
  <link name="neck_1"/><link name="neck_2"/><link name="head"/>
  <link name="eyes"/><link name="left_eye"/><link name="right_eye"/>
  <link name="cam0_optical"/><link name="cam1_optical"/>
  <joint name="neck_pitch" type="revolute">
    <parent link="base"/><child link="neck_1"/>
    <origin xyz="0 0 0.10" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-0.6" upper="0.6" effort="1" velocity="1"/>
  </joint>
  <joint name="neck_roll" type="revolute">
    <parent link="neck_1"/><child link="neck_2"/>
    <origin xyz="0 0 0.03" rpy="0 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.6" upper="0.6" effort="1" velocity="1"/>
  </joint>
  <joint name="neck_yaw" type="revolute">
    <parent link="neck_2"/><child link="head"/>
    <origin xyz="0 0 0.05" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-0.9" upper="0.9" effort="1" velocity="1"/>
  </joint>
  <joint name="eyes_tilt" type="revolute">
    <parent link="head"/><child link="eyes"/>
    <origin xyz="0.06 0 0.07" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-0.5" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <joint name="left_eye_pan" type="revolute">
    <parent link="eyes"/><child link="left_eye"/>
    <origin xyz="0 0.034 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-0.5" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <joint name="right_eye_pan" type="revolute">
    <parent link="eyes"/><child link="right_eye"/>
    <origin xyz="0 -0.034 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-0.5" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <joint name="left_optical" type="fixed">
    <parent link="left_eye"/><child link="cam0_optical"/>
    <origin xyz="0 0 0" rpy="-1.5707963267948966 0 -1.5707963267948966"/>
  </joint>
  <joint name="right_optical" type="fixed">
    <parent link="right_eye"/><child link="cam1_optical"/>
    <origin xyz="0 0 0" rpy="-1.5707963267948966 0 -1.5707963267948966"/>
  </joint>
</robot>)";

}  // namespace epmap::testing
