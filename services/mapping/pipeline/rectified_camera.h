#pragma once
// What the pipeline's consumers of rectified frames (expected perception, the maps) share about
// the rectified left camera: whether its geometry changed, and where it sits in the raw camera.

#include <Eigen/Geometry>

#include "perception/stereo/rectification.h"

namespace epmap::mapping {

// Same image size, intrinsics and baseline: state built on one frame still applies to the next.
inline bool SameGeometry(const stereo::RectifiedGeometry& a, const stereo::RectifiedGeometry& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.baseline_m == b.baseline_m;
}

// The rectified left camera in the raw one: x_rect = R x_raw, so it sits at [R^T | 0]
// (T_raw_rect; a raw camera pose times this is the rectified camera's pose).
inline Eigen::Isometry3d RawToRectified(const stereo::Rectifier& rectifier) {
  Eigen::Isometry3d T_raw_rect = Eigen::Isometry3d::Identity();
  const cv::Matx33d& R = rectifier.left_rotation();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T_raw_rect.linear()(r, c) = R(c, r);
  }
  return T_raw_rect;
}

}  // namespace epmap::mapping
