#include "services/mapping/calibration/active_models.h"

namespace epmap::mapping {

std::shared_ptr<const ActiveModels::EyeHand> ActiveModels::eye_hand() const {
  std::lock_guard lock(mutex_);
  return eye_hand_;
}

std::shared_ptr<const ActiveModels::Stereo> ActiveModels::stereo() const {
  std::lock_guard lock(mutex_);
  return stereo_;
}

Eigen::Vector3d ActiveModels::CorrectVisionPoint(const Eigen::Vector3d& x_base) const {
  const auto model = eye_hand();
  return model ? model->model.Apply(x_base) : x_base;
}

std::string ActiveModels::eye_hand_id() const {
  const auto model = eye_hand();
  return model ? model->id : std::string();
}

std::string ActiveModels::stereo_id() const {
  const auto model = stereo();
  return model ? model->id : std::string();
}

void ActiveModels::SetEyeHand(std::shared_ptr<const EyeHand> model) {
  std::lock_guard lock(mutex_);
  eye_hand_ = std::move(model);
}

void ActiveModels::SetStereo(std::shared_ptr<const Stereo> model) {
  std::lock_guard lock(mutex_);
  stereo_ = std::move(model);
}

}  // namespace epmap::mapping
