#pragma once
// The stereo-extrinsics job (paper 001, Sec. III-A, run on the live stream): take N raw frames
// from the pipeline (spaced in time, so that the eyes are in different configurations), give
// each its kinematic prior T_cam0_cam1 from the joint readings interpolated at its stamp
// through the URDF (cam0_optical, cam1_optical) and its intrinsics K, D from CameraInfo, run
// SelfCalibrateStereo on each frame, and combine the per-frame corrections to the prior by their
// median (stereo_correction.h). The result is measured on the frames it came from: the median
// vertical offset of SIFT matches after rectifying with prior * C, beside the prior alone.

#include <epmap/v1/calibration_service.pb.h>

#include <cstdint>
#include <optional>
#include <string>

#include "perception/calibration/calibration_error.h"
#include "perception/calibration/stereo_self_calibration.h"
#include "perception/kinematics/urdf_chain.h"
#include "services/mapping/calibration/frame_tap.h"
#include "services/mapping/calibration/stereo_correction.h"
#include "services/mapping/config/service_config.h"
#include "services/mapping/ingest/sensor_state.h"

namespace epmap::mapping {

// What the job reads from the running service.
struct StereoJobEnvironment {
  RawFrameTap* tap = nullptr;
  SensorState* sensors = nullptr;
  const kinematics::UrdfChain* chain = nullptr;  // null: no URDF configured
  std::string urdf_path;                         // for messages
  uint32_t dds_domain = 0;
  std::string image_topics;  // for messages
  int64_t joints_max_gap_ns = 200'000'000;
  int64_t joints_wait_ns = 100'000'000;
  CalibrationSettings settings;
};

// CameraInfo (ROS terms) -> the self-calibration's intrinsics; nullopt + *reason for a
// distortion model the self-calibration does not handle.
std::optional<calibration::CameraIntrinsics> IntrinsicsFromCameraInfo(
    const dds::CameraCalibration& camera_info, std::string* reason);

v1::StereoExtrinsicsSpec WithDefaults(v1::StereoExtrinsicsSpec spec,
                                      const CalibrationSettings& settings);
std::string CheckStereoSpec(const v1::StereoExtrinsicsSpec& spec);

struct StereoJobResult {
  StereoCorrectionModel model;
  v1::ModelErrors errors;
  std::string description;
};

// Throws calibration::CalibrationError with a reason a person can act on: no URDF with
// cam1_optical, no frames within the timeout, no CameraInfo or joint readings, too few frames
// that self-calibrate (featureless or planar scene, rejected by the prior: the most common
// reason is given), kCancelled when `progress` asks to stop.
StereoJobResult RunStereoJob(const v1::StereoExtrinsicsSpec& spec, const StereoJobEnvironment& env,
                             const calibration::ProgressCallback& progress);

}  // namespace epmap::mapping
