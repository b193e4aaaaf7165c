#include "perception/mobile_mapping/key_frame_selector.h"

#include <cmath>
#include <stdexcept>

namespace epmap::mobile_mapping {

void KeyFrameSelectorParams::Validate() const {
  if (!(min_translation_m > 0) || !(min_rotation_rad > 0) || !(min_camera_rotation_rad > 0)) {
    throw std::invalid_argument("key frame selector: thresholds must be > 0");
  }
}

KeyFrameSelector::KeyFrameSelector(const KeyFrameSelectorParams& params) : params_(params) {
  params_.Validate();
}

bool KeyFrameSelector::Consider(const Eigen::Isometry2d& T_odom_base,
                                const Eigen::Isometry3d& T_base_cam) {
  bool key = !last_base_.has_value();
  if (!key) {
    const Eigen::Isometry2d step = last_base_->inverse() * T_odom_base;
    const double turn = std::abs(std::atan2(step.linear()(1, 0), step.linear()(0, 0)));
    const Eigen::AngleAxisd head(last_cam_.linear().transpose() * T_base_cam.linear());
    key = step.translation().norm() >= params_.min_translation_m ||
          turn >= params_.min_rotation_rad ||
          std::abs(head.angle()) >= params_.min_camera_rotation_rad;
  }
  if (key) {
    last_base_ = T_odom_base;
    last_cam_ = T_base_cam;
  }
  return key;
}

}  // namespace epmap::mobile_mapping
