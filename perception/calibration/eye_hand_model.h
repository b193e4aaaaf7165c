#pragma once
// The learned vision-to-kinematics map f(X_A) = X_B of paper 001, Sec. III-B: one rigid
// transform H* (Eq. 9), optionally with an anisotropic scale, or a mixture of such experts
// blended by normalised Mahalanobis radial basis functions (Eq. 10). Serialises to JSON so that
// the calibration service can store, list and reload models.

#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

#include "perception/calibration/eye_hand_samples.h"

namespace epmap::calibration {

enum class EyeHandMethod {
  kSe3,       // x_B = R x_A + t                 (Eq. 9)
  kSe3Scale,  // x_B = R diag(s) x_A + t         (anisotropic scale in the vision frame's axes)
  kMixture,   // x_B = sum_i w_i(x_A) H_i x_A    (Eq. 10)
};
const char* ToString(EyeHandMethod method);  // "se3", "se3-scale", "mixture"
// Throws CalibrationError(kInvalidInput) listing the accepted names.
EyeHandMethod ParseEyeHandMethod(std::string_view name);

// One linear expert H = [R diag(s) | t], mapping vision (ROOT) points to kinematic (ROOT)
// points. Scale is applied along the vision frame's axes *before* the rotation: the error it
// models (a stereo depth/baseline scale) lives in the measuring frame, not in the target frame.
// With s = (1,1,1) it is an element of SE(3).
struct LinearExpert {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  // Region of competence in the vision frame (Eq. 10: c_i, S_i); unused by single-transform
  // models. The covariance is stored already regularised and must be positive definite.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();

  Eigen::Matrix3d Linear() const { return rotation * scale.asDiagonal(); }
  Eigen::Vector3d Apply(const Eigen::Vector3d& x_a) const { return Linear() * x_a + translation; }
  Eigen::Matrix4d Matrix() const;
};

class EyeHandModel {
 public:
  // The identity map (no calibration).
  EyeHandModel();
  // Validates the experts (a rotation matrix each, positive finite scales, a positive definite
  // covariance for mixtures) and throws CalibrationError(kInvalidInput) saying which is wrong.
  EyeHandModel(EyeHandMethod method, std::vector<LinearExpert> experts);

  EyeHandMethod method() const { return method_; }
  const std::vector<LinearExpert>& experts() const { return experts_; }

  // f(X_A): the single expert, or the Eq. 10 blend of all experts.
  Eigen::Vector3d Apply(const Eigen::Vector3d& x_a) const;
  Eigen::Matrix3Xd Apply(const Eigen::Matrix3Xd& x_a) const;
  // The Eq. 10 weights w_i(x_a) (sum 1); a single expert has weight 1.
  Eigen::VectorXd Weights(const Eigen::Vector3d& x_a) const;

  std::string ToJson() const;
  // Throws CalibrationError(kInvalidInput) with the reason on malformed or invalid JSON.
  static EyeHandModel FromJson(std::string_view json);

 private:
  EyeHandMethod method_ = EyeHandMethod::kSe3;
  std::vector<LinearExpert> experts_;
  std::vector<Eigen::Matrix3d> covariance_inverse_;
};

// Distances ||X_B - f(X_A)|| summarised.
struct ErrorSummary {
  size_t count = 0;
  double mean_m = 0, rmse_m = 0, median_m = 0, max_m = 0;
};
ErrorSummary Summarise(std::vector<double> distances);
ErrorSummary EvaluateModel(const EyeHandModel& model, const std::vector<EyeHandSample>& samples);
// ||X_B - X_A||: the error of the uncalibrated system.
ErrorSummary EvaluateUncalibrated(const std::vector<EyeHandSample>& samples);

}  // namespace epmap::calibration
