// The pipeline's side of the calibration service (services/mapping/calibration/README.md):
// raw frames go to the stereo-extrinsics jobs' tap, and an active stereo-extrinsics model
// replaces CameraInfo's rectification with one built from each frame's kinematic prior
// corrected by the model.

#include <spdlog/spdlog.h>

#include "perception/calibration/stereo_self_calibration.h"
#include "services/mapping/pipeline/pipeline.h"

namespace epmap::mapping {

void Pipeline::AttachCalibration(const ActiveModels* models, RawFrameTap* tap,
                                 double rectification_rebuild_deg) {
  active_models_ = models;
  frame_tap_ = tap;
  model_rectification_.emplace(rectification_rebuild_deg);
}

const stereo::Rectifier* Pipeline::StereoModelRectifier(const StereoFrame& frame,
                                                        const ActiveModels::Stereo& model) {
  // The model corrects the kinematic prior of the frame's eye configuration.
  if (!chain_ || !chain_->has_cam1()) {
    counters_.rejected.Increment("pipeline:stereo_model_needs_urdf_with_cam1");
    return nullptr;
  }
  std::string reason;
  const auto joints =
      sensors_.JointsAt(frame.stamp_ns, chain_->joint_names(), config_.joints_max_gap_ns,
                        std::chrono::nanoseconds(config_.joints_wait_ns), &reason);
  if (!joints) {
    counters_.rejected.Increment("pipeline:stereo_model_" + reason);
    return nullptr;
  }
  auto infos = sensors_.camera_infos();
  if (!infos.left || !infos.right) {
    const auto age = std::chrono::steady_clock::now() - frame.assembled;
    const auto wait = std::chrono::nanoseconds(config_.camera_info_wait_ns) - age;
    if (wait.count() > 0) sensors_.WaitForCameraInfos(wait);
    infos = sensors_.camera_infos();
  }
  const uint64_t rebuilds_before = model_rectification_->rebuilds();
  const auto t0 = std::chrono::steady_clock::now();
  const stereo::Rectifier* rectifier = model_rectification_->For(
      model, infos, calibration::KinematicPrior(*chain_, *joints), &reason);
  if (!rectifier) {
    counters_.rejected.Increment("pipeline:" + reason);
    return nullptr;
  }
  if (model_rectification_->rebuilds() != rebuilds_before) {
    stage_ms_->Add(
        "stereo_model_maps",
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    events_.Increment("stereo_model_rectification_rebuilt");
    if (rebuilds_before == 0) {
      spdlog::info("rectification from stereo model {}: fx {:.2f}, baseline {:.4f} m", model.id,
                   rectifier->geometry().fx, rectifier->geometry().baseline_m);
    }
  }
  const auto& g = rectifier->geometry();
  if (frame.left.cols != g.width || frame.left.rows != g.height) {
    counters_.rejected.Increment("pipeline:image_size_differs_from_camera_info");
    return nullptr;
  }
  return rectifier;
}

}  // namespace epmap::mapping
