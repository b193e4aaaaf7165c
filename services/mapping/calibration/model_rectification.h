#pragma once
// Rectification under an active stereo-extrinsics model, for the pipeline. The frame's
// extrinsics are its kinematic prior corrected by the model (T_prior(joints) * C, see
// stereo_correction.h); with the cameras' K and D from CameraInfo they give Bouguet
// rectification maps (perception/calibration MakeRectifier), replacing the CameraInfo's R and P.
// Building the maps costs ~10 ms at 640x480, so they are rebuilt only when the model or the
// CameraInfo changed, or when the extrinsics moved by more than a threshold since the maps were
// built (eyes that verge change them every frame; a still head never does).

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>

#include "perception/stereo/rectification.h"
#include "services/mapping/calibration/active_models.h"
#include "services/mapping/ingest/sensor_state.h"

namespace epmap::mapping {

class ModelRectification {
 public:
  explicit ModelRectification(double rebuild_threshold_deg)
      : threshold_deg_(rebuild_threshold_deg) {}

  // The rectifier for a frame with kinematic prior T_cam0_cam1_prior under `model`; nullptr
  // with *reason (a counter name) when CameraInfo cannot give the intrinsics or the maps cannot
  // be built.
  const stereo::Rectifier* For(const ActiveModels::Stereo& model,
                               const SensorState::CameraInfos& infos,
                               const Eigen::Isometry3d& T_cam0_cam1_prior, std::string* reason);

  uint64_t rebuilds() const { return rebuilds_; }
  // The extrinsics the current maps were built for.
  const std::optional<Eigen::Isometry3d>& built_for() const { return built_for_; }

 private:
  const double threshold_deg_;
  std::optional<stereo::Rectifier> rectifier_;
  std::optional<Eigen::Isometry3d> built_for_;
  std::string model_id_;
  uint64_t infos_version_ = ~0ull;
  uint64_t rebuilds_ = 0;
};

}  // namespace epmap::mapping
