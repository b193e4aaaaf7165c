#pragma once
// Which frames are key frames. Paper 002 takes every m-th frame (m = 3) of a robot driving at
// constant speed; a robot that stops, pans and drives at varying speed is better served by the
// motion itself: a key frame when the base has moved or turned, or the head has panned, enough
// since the last one. Motion that large is still trackable thanks to the prediction of the
// feature positions from the odometry (Sec. 3.3).

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>

namespace epmap::mobile_mapping {

struct KeyFrameSelectorParams {
  double min_translation_m = 0.25;
  double min_rotation_rad = 0.15;         // base turn (8.6 degrees)
  double min_camera_rotation_rad = 0.15;  // head pan relative to the base
  void Validate() const;
};

class KeyFrameSelector {
 public:
  explicit KeyFrameSelector(const KeyFrameSelectorParams& params = {});
  // True if this frame should be a key frame (the first frame always is); it then becomes the
  // reference for the next decision.
  bool Consider(const Eigen::Isometry2d& T_odom_base, const Eigen::Isometry3d& T_base_cam);

 private:
  KeyFrameSelectorParams params_;
  std::optional<Eigen::Isometry2d> last_base_;
  Eigen::Isometry3d last_cam_ = Eigen::Isometry3d::Identity();
};

}  // namespace epmap::mobile_mapping
