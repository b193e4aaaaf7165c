#pragma once
// Rectification as ROS's image_proc does it: each camera's K, D, R, P (the CameraInfo of a
// calibrated driver) give an undistort-rectify map; the rectified pair has row-aligned
// epipolar lines, focal length P(0,0) and baseline -P_right(0,3) / P_right(0,0).

#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera/camera_model.h"

namespace epmap::stereo {

// One camera's calibration in ROS CameraInfo terms.
using CameraParameters = camera::CameraModel;

// The pinhole model of the rectified left camera and the stereo baseline.
struct RectifiedGeometry {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double baseline_m = 0;  // > 0; depth z = fx * baseline / disparity
};

class Rectifier {
 public:
  Rectifier() = default;
  // Builds the maps. Throws std::invalid_argument if the two cameras disagree in size, a
  // matrix is degenerate or the right camera's P carries no baseline.
  Rectifier(const CameraParameters& left, const CameraParameters& right);

  // Rectifies a pair (any type the cameras deliver). When both cameras are already
  // rectified (no distortion, R = I, P = K) the images pass through untouched.
  void Rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left,
               cv::Mat& right) const;

  const RectifiedGeometry& geometry() const { return geometry_; }
  bool identity() const { return identity_; }
  // R of the left camera: x_rect = R x_raw. The rectified left camera's pose in the raw one is
  // [R^T | 0], which turns a raw camera pose (e.g. from kinematics) into the rectified one.
  const cv::Matx33d& left_rotation() const { return left_rotation_; }
  bool valid() const { return geometry_.width > 0; }

 private:
  RectifiedGeometry geometry_;
  bool identity_ = false;
  cv::Matx33d left_rotation_ = cv::Matx33d::eye();
  cv::Mat map_left_x_, map_left_y_, map_right_x_, map_right_y_;
};

// The rectification a calibrated ROS stereo driver would publish for two cameras with
// intrinsics K, distortion D and poses T_BS on a body (EuRoC sensor.yaml), computed with
// cv::stereoRectify (alpha = 0: only valid pixels). Fills R and P of both.
void StereoRectifyFromExtrinsics(const cv::Matx33d& k_left, const std::vector<double>& d_left,
                                 const cv::Matx33d& k_right, const std::vector<double>& d_right,
                                 const cv::Matx44d& T_body_left, const cv::Matx44d& T_body_right,
                                 const cv::Size& size, const std::string& distortion_model,
                                 CameraParameters* left, CameraParameters* right);

}  // namespace epmap::stereo
