#pragma once
// The eye-hand calibration job (paper 001, Sec. III-B): choose training and hold-out samples
// from a stored set as the spec says, run perception/calibration's CalibrateEyeHand, and turn
// the result into what the service stores (model JSON, ModelErrors, a description).

#include <epmap/v1/calibration_service.pb.h>

#include <string>
#include <vector>

#include "perception/calibration/eye_hand_calibration.h"

namespace epmap::mapping {

inline constexpr const char* kDefaultSampleSet = "default";

// The spec with every default made explicit (what the job record shows).
v1::EyeHandSpec WithDefaults(v1::EyeHandSpec spec);
// The reason the spec is invalid (for INVALID_ARGUMENT), or "" when it is fine.
std::string CheckEyeHandSpec(const v1::EyeHandSpec& spec);

struct EyeHandJobResult {
  calibration::EyeHandCalibrationResult fit;
  v1::ModelErrors errors;
  std::string description;  // method, experts, data used
};

// `samples`: the spec's set. Throws calibration::CalibrationError with a reason a person can act
// on (no samples, unknown hold-out path, too few / collinear samples, K too large, cancelled).
EyeHandJobResult RunEyeHandJob(const v1::EyeHandSpec& spec,
                               const std::vector<calibration::EyeHandSample>& samples,
                               const calibration::ProgressCallback& progress);

}  // namespace epmap::mapping
