#pragma once
// The eye-hand calibration job as the calibration service runs it: fit the chosen model on the
// training samples, measure it on held-out samples, report progress and honour cancellation.
// Paper 001, Sec. III-B (Eq. 9, Eq. 10).

#include <vector>

#include "perception/calibration/calibration_error.h"
#include "perception/calibration/eye_hand_model.h"
#include "perception/calibration/mixture.h"
#include "perception/calibration/se3_fit.h"

namespace epmap::calibration {

struct EyeHandCalibrationParams {
  EyeHandMethod method = EyeHandMethod::kSe3;
  Se3FitParams se3;       // se3 and se3-scale (anisotropic_scale is set from `method`)
  MixtureParams mixture;  // mixture
};

// Distances ||X_B - f(X_A)|| (mirrors epmap.v1.ModelErrors).
struct EyeHandErrors {
  ErrorSummary initial;        // ||X_B - X_A|| on the test samples (training if none)
  ErrorSummary train;          // every training sample, outliers included
  ErrorSummary train_inliers;  // the samples the model was fitted on
  ErrorSummary test;           // held-out samples (count 0 if none)
  size_t outliers_rejected = 0;
  int experts = 1;
};

struct EyeHandCalibrationResult {
  EyeHandModel model;
  EyeHandErrors errors;
  std::vector<CrossValidationScore> cross_validation;  // mixture with K chosen by CV
};

// Throws CalibrationError (see FitSe3 and FitMixture) with a reason a person can act on.
EyeHandCalibrationResult CalibrateEyeHand(const std::vector<EyeHandSample>& train,
                                          const std::vector<EyeHandSample>& test,
                                          const EyeHandCalibrationParams& params = {},
                                          const ProgressCallback& progress = {});

}  // namespace epmap::calibration
