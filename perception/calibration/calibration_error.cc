#include "perception/calibration/calibration_error.h"

namespace epmap::calibration {

const char* ToString(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidInput:
      return "invalid-input";
    case ErrorCode::kDegenerate:
      return "degenerate";
    case ErrorCode::kCancelled:
      return "cancelled";
    case ErrorCode::kNotConverged:
      return "not-converged";
    case ErrorCode::kInsufficientFeatures:
      return "insufficient-features";
    case ErrorCode::kPlanarScene:
      return "planar-scene";
    case ErrorCode::kRejectedByPrior:
      return "rejected-by-prior";
  }
  return "unknown";
}

void ReportProgress(const ProgressCallback& callback, const Progress& progress) {
  if (callback && !callback(progress)) {
    throw CalibrationError(ErrorCode::kCancelled, "cancelled during '" + progress.stage +
                                                      "' at iteration " +
                                                      std::to_string(progress.iteration));
  }
}

}  // namespace epmap::calibration
