#pragma once
// How the calibration algorithms fail, and how long-running fits report progress and get
// cancelled. Every failure is a CalibrationError carrying a code (the service maps it onto a job
// state and a gRPC status) and a message a person can act on.

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>

namespace epmap::calibration {

enum class ErrorCode {
  kInvalidInput,          // malformed input: NaN, empty, sizes that do not agree
  kDegenerate,            // the data cannot determine the model (collinear, planar, too few)
  kCancelled,             // the progress callback asked to stop
  kNotConverged,          // the solver gave up without a usable answer
  kInsufficientFeatures,  // stereo: too few textured features or matches
  kPlanarScene,           // stereo: the matches are explained by a homography, F is undetermined
  kRejectedByPrior,       // stereo: the recovered geometry is too far from the kinematic prior
};

const char* ToString(ErrorCode code);

class CalibrationError : public std::runtime_error {
 public:
  CalibrationError(ErrorCode code, const std::string& message)
      : std::runtime_error(message), code_(code) {}
  ErrorCode code() const { return code_; }

 private:
  ErrorCode code_;
};

// What a long-running fit reports. `fraction` is the share of the whole job done (0..1),
// `iteration` counts the current solver's objective evaluations (or RANSAC iterations), `cost`
// is that solver's current objective (mean squared error in m^2 for eye-hand fits, mean squared
// Sampson distance in px^2 for stereo).
struct Progress {
  std::string stage;
  uint64_t iteration = 0;
  double cost = 0.0;
  double fraction = 0.0;
};

// Called from inside the fit; return false to cancel (the fit then throws CalibrationError with
// ErrorCode::kCancelled). An empty function never cancels. Must be cheap: it may be called once
// per objective evaluation.
using ProgressCallback = std::function<bool(const Progress&)>;

// Calls `callback` if set and throws kCancelled when it asks to stop.
void ReportProgress(const ProgressCallback& callback, const Progress& progress);

}  // namespace epmap::calibration
