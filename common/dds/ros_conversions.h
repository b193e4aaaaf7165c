#pragma once
// Conversions between ROS 2 messages (as generated from proto/dds) and the project's types:
// cv::Mat for images, a plain struct for camera calibration, nanoseconds for stamps.
// Validation lives here too, so every reader refuses the same bad input for the same reason.

#include <epmap_dds/CameraInfo.h>
#include <epmap_dds/Image.h>
#include <epmap_dds/JointState.h>
#include <epmap_dds/Odometry.h>

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/camera/camera_model.h"

namespace epmap::dds {

int64_t ToNanoseconds(const builtin_interfaces::msg::Time& t);
builtin_interfaces::msg::Time FromNanoseconds(int64_t ns);

// Image -> cv::Mat (a deep copy). Supported encodings: mono8, bgr8, rgb8 (converted to BGR),
// mono16, 16UC1, 32FC1. On failure returns an empty Mat and sets *reason to a short counter
// name: "empty", "unknown_encoding", "size_mismatch" (width/height/step/data disagree),
// "big_endian".
cv::Mat ImageToMat(const sensor_msgs::msg::Image& msg, std::string* reason);
// Fills an Image message from a cv::Mat of type CV_8UC1, CV_8UC3 (bgr8), CV_16UC1 or CV_32FC1.
void MatToImage(const cv::Mat& image, int64_t stamp_ns, const std::string& frame_id,
                sensor_msgs::msg::Image* msg);

// A camera's calibration as a calibrated ROS driver publishes it in CameraInfo.
using CameraCalibration = camera::CameraModel;

// CameraInfo -> CameraCalibration; nullopt with *reason ("camera_info_invalid") when the
// sizes are zero, K is singular or values are not finite.
std::optional<CameraCalibration> FromCameraInfo(const sensor_msgs::msg::CameraInfo& msg,
                                                std::string* reason);
void ToCameraInfo(const CameraCalibration& calib, int64_t stamp_ns, const std::string& frame_id,
                  sensor_msgs::msg::CameraInfo* msg);

struct JointReading {
  int64_t stamp_ns = 0;
  std::vector<std::string> names;
  std::vector<double> positions;
};
// JointState -> JointReading; nullopt with *reason "joints_nan" (non-finite position),
// "joints_size_mismatch" (names and positions differ in length) or "empty".
std::optional<JointReading> FromJointState(const sensor_msgs::msg::JointState& msg,
                                           std::string* reason);
void ToJointState(const JointReading& reading, sensor_msgs::msg::JointState* msg);

struct PlanarOdometry {
  int64_t stamp_ns = 0;
  double x = 0, y = 0, theta = 0;  // base in the odometry frame
};
// Odometry -> planar pose (yaw from the quaternion); nullopt with *reason "odom_nan".
std::optional<PlanarOdometry> FromOdometry(const nav_msgs::msg::Odometry& msg, std::string* reason);
void ToOdometry(const PlanarOdometry& odom, const std::string& frame_id,
                const std::string& child_frame_id, nav_msgs::msg::Odometry* msg);

}  // namespace epmap::dds
