#include "services/mapping/calibration/model_rectification.h"

#include "perception/calibration/stereo_self_calibration.h"
#include "services/mapping/calibration/stereo_job.h"

namespace epmap::mapping {

const stereo::Rectifier* ModelRectification::For(const ActiveModels::Stereo& model,
                                                 const SensorState::CameraInfos& infos,
                                                 const Eigen::Isometry3d& T_cam0_cam1_prior,
                                                 std::string* reason) {
  if (!infos.left || !infos.right) {
    *reason = "no_camera_info";
    return nullptr;
  }
  const Eigen::Isometry3d T = model.model.Apply(T_cam0_cam1_prior);
  const bool same_inputs = rectifier_ && model_id_ == model.id && infos_version_ == infos.version;
  if (same_inputs && built_for_ &&
      calibration::RotationAngleDeg(built_for_->linear(), T.linear()) <= threshold_deg_ &&
      calibration::DirectionAngleDeg(built_for_->translation(), T.translation()) <=
          threshold_deg_) {
    return &*rectifier_;
  }
  std::string why;
  const auto c0 = IntrinsicsFromCameraInfo(*infos.left, &why);
  const auto c1 = c0 ? IntrinsicsFromCameraInfo(*infos.right, &why) : std::nullopt;
  if (!c0 || !c1) {
    *reason = "stereo_model_unsupported_camera_info";
    return nullptr;
  }
  try {
    rectifier_ = calibration::MakeRectifier(*c0, *c1, T);
  } catch (const std::exception&) {
    rectifier_.reset();
    built_for_.reset();
    *reason = "stereo_model_cannot_rectify";
    return nullptr;
  }
  built_for_ = T;
  model_id_ = model.id;
  infos_version_ = infos.version;
  ++rebuilds_;
  return &*rectifier_;
}

}  // namespace epmap::mapping
