#pragma once
// Eq. 9 of paper 001: H* = argmin_H (1/N) sum_i ||X_B^i - H X_A^i||^2 over H in SE(3), solved
// with NLopt's gradient-based L-BFGS on an analytic gradient; optionally H = [R diag(s) | t]
// (method se3-scale). Outliers are rejected by a robust residual rule and the fit repeated.
//
// Parametrisation (no singularity at the solution): R = R0 * Exp([w]x) with w a rotation vector
// perturbing the current estimate R0. The gradient in w is J_r(w)^T g, J_r the right Jacobian
// of SO(3). When a solve ends with |w| large, R0 is re-centred on the result and the solve is
// repeated, so the final answer always sits at w ~ 0, far from the chart's singularity at
// |w| = 2 pi. Scales are s = exp(sigma) (always positive); the translation is solved for in
// centred, normalised coordinates (see Se3Objective), which decouples it from the rotation.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "perception/calibration/calibration_error.h"
#include "perception/calibration/eye_hand_model.h"

namespace epmap::calibration {

// Residual-based outlier rejection, repeated until the inlier set is stable: a sample is an
// outlier when r_i = ||X_B - H X_A|| exceeds
//     max( median(r) + k * 1.4826 * MAD(r),  floor_m ),
// MAD(r) = median(|r_i - median(r)|) over all samples (1.4826 * MAD estimates a Gaussian sigma).
// The floor keeps clean data (residuals of a few mm) from losing its tail to the rule.
struct OutlierRejection {
  bool enabled = true;
  double k = 3.0;
  double floor_m = 0.01;
  int max_rounds = 10;
  // More rejected than this share means the data does not follow one map: an error.
  double max_rejected_share = 0.5;
};

struct Se3FitParams {
  bool anisotropic_scale = false;  // se3-scale
  enum class Init { kIdentity, kUmeyama };
  // Where the NLopt solve starts. kIdentity makes NLopt do all the work (tests use it);
  // kUmeyama starts from the closed form (faster, same optimum for plain SE(3)).
  Init init = Init::kUmeyama;
  OutlierRejection outliers;
  // Observability. Let sigma_1 >= sigma_2 >= sigma_3 be the principal standard deviations of
  // the X_A samples. They are "on a line" when sigma_2 < max(line_ratio * sigma_1, min_spread_m)
  // (the rotation about the line is then unobservable: refused for every method), and "on a
  // plane" when sigma_3 < max(plane_ratio * sigma_1, min_spread_m) (fine for SE(3): three
  // non-collinear points fix a rigid transform; refused for se3-scale: the scale along the
  // plane's normal is not determined by the data).
  double line_ratio = 0.03;
  double plane_ratio = 0.05;
  double min_spread_m = 1e-4;
  // NLopt L-BFGS stopping rules (objective in normalised units, see Se3Objective).
  double ftol_rel = 1e-15;
  double xtol_abs = 1e-12;
  int max_evaluations = 2000;
  int max_recentres = 4;
  double recentre_above_rad = 0.05;
};

struct Se3FitStats {
  size_t samples = 0;
  size_t inliers = 0;
  size_t rejected = 0;
  int rounds = 0;        // outlier-rejection rounds (fits) performed
  int evaluations = 0;   // NLopt objective evaluations, all rounds
  double cost_m2 = 0.0;  // final Eq. 9 objective over the inliers
  ErrorSummary inlier_errors;
};

struct Se3FitResult {
  LinearExpert transform;  // centroid/covariance of the inlier X_A filled in as well
  Se3FitStats stats;
  std::vector<uint8_t> inlier;  // per sample
};

// xa, xb: 3xN vision and kinematic points (column i is sample i). Throws CalibrationError:
// kInvalidInput (size mismatch, NaN), kDegenerate (too few, collinear; planar with scale; too
// many outliers), kCancelled, kNotConverged.
Se3FitResult FitSe3(const Eigen::Matrix3Xd& xa, const Eigen::Matrix3Xd& xb,
                    const Se3FitParams& params = {}, const ProgressCallback& progress = {});

// Closed-form least-squares rigid transform (Eigen::umeyama, no scale): the oracle the NLopt
// solution is checked against. Same input checks as FitSe3, no outlier rejection.
LinearExpert UmeyamaSe3(const Eigen::Matrix3Xd& xa, const Eigen::Matrix3Xd& xb);

// Throws CalibrationError(kDegenerate) when the points cannot determine the map (see
// Se3FitParams); `what` names the data in the message ("cluster 3", "path p07", ...).
void CheckObservability(const Eigen::Matrix3Xd& xa, const Se3FitParams& params,
                        const std::string& what = "the samples");

// The Eq. 9 objective and its analytic gradient, exposed for the gradient check. Points are
// centred (a~ = a - mean(a), b~ = b - mean(b)) and divided by one length L = rms|a~|, so
//   f(x) = (1/N) sum |b~/L - M a~/L - tau|^2
//        = tr(Cbb) - 2 tr(M^T Cba) + tr(M^T M Caa) + |tau|^2,      M = R0 Exp(w) diag(exp(sigma))
// with the moments Caa, Cba, Cbb of the normalised centred points: one evaluation costs O(1)
// whatever N. x = [w (3), tau (3)] or [w, tau, sigma (3)] with scale. The metric objective of
// Eq. 9 is L^2 * f.
class Se3Objective {
 public:
  Se3Objective(const Eigen::Matrix3Xd& xa, const Eigen::Matrix3Xd& xb,
               const std::vector<uint8_t>* mask, bool with_scale);

  int dimension() const { return with_scale_ ? 9 : 6; }
  double length_scale() const { return length_; }
  const Eigen::Matrix3d& anchor() const { return anchor_; }

  // f(x) in normalised units; fills grad (dimension() values) when non-null.
  double Evaluate(const double* x, double* grad) const;
  // The metric transform for parameters x (anchored at anchor()).
  LinearExpert Decode(const double* x) const;
  // Re-anchors at `t`'s rotation and writes the parameters that represent `t` (w = 0).
  void Encode(const LinearExpert& t, double* x);

 private:
  bool with_scale_;
  double length_ = 1.0;
  Eigen::Vector3d mean_a_, mean_b_;
  Eigen::Matrix3d caa_, cba_;
  double cbb_ = 0.0;
  Eigen::Matrix3d anchor_ = Eigen::Matrix3d::Identity();
};

// Exp and right Jacobian of SO(3) (rotation vector w).
Eigen::Matrix3d ExpSo3(const Eigen::Vector3d& w);
Eigen::Matrix3d RightJacobianSo3(const Eigen::Vector3d& w);

}  // namespace epmap::calibration
