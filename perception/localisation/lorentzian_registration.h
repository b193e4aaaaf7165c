#pragma once
// Paper 002, Sec. 3.3: the rototranslation (R, t) between two key frames that minimises
//   sum_i rho_i(||d_i||^2),  d_i = X''_i - (R X'_i + t),  rho_i(s) = log(1 + s / sigma_i^2)
// (the Lorentzian: outliers get a weight that falls as 1/||d||^2). sigma_i lets far points,
// whose stereo depth is less accurate, count less. The vertical component of R gives the
// visual estimate of the heading change.
//
// Minimised by iteratively reweighted least squares: with w_i = 1 / (sigma_i^2 + ||d_i||^2),
// the derivative of rho_i, each step is a weighted absolute orientation problem solved in
// closed form (weighted Kabsch/Umeyama); the cost never increases since rho is concave in
// ||d||^2 (a majorise-minimise step).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace epmap::localisation {

struct LorentzianParams {
  int max_iterations = 50;
  double tolerance = 1e-9;  // stop when the rotation and translation change less than this
  int min_pairs = 6;        // fewer pairs cannot give a trustworthy motion
  // A pair counts as an inlier when its residual is within this many of its sigmas.
  double inlier_sigmas = 3.0;
  // Restrict R to a rotation about the vertical (z) axis: a planar robot's motion. Off by
  // default, as in the paper (full rototranslation, then its vertical component).
  bool vertical_axis_only = false;
  // Take the translation as known (RegisterLorentzianRotation): with a 65 degree field of
  // view and points mostly ahead, a small yaw and a sideways shift move the points almost
  // alike, so a free translation soaks up part of the heading change. Wheel odometry's
  // translation over one key-frame step is accurate (its heading is what drifts), so the
  // mobile mapper fixes it and fits the rotation only (see RegisterLorentzianRotation).
  void Validate() const;
};

struct RigidFit {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();  // X'' ~ T X' (T_cur_prev)
  double cost = 0;                                      // Lorentzian cost at T
  int pairs = 0;
  int inliers = 0;
  int iterations = 0;
  bool ok = false;
  std::string reason;  // why not ok
};

// Sum of rho_i(||X''_i - T X'_i||^2).
double LorentzianCost(const std::vector<Eigen::Vector3d>& x_prev,
                      const std::vector<Eigen::Vector3d>& x_cur, const std::vector<double>& sigma,
                      const Eigen::Isometry3d& T);

// Fits T_cur_prev starting from `initial` (e.g. the odometry's prediction). Throws
// std::invalid_argument if the three vectors differ in length or a sigma is not positive.
RigidFit RegisterLorentzian(const std::vector<Eigen::Vector3d>& x_prev,
                            const std::vector<Eigen::Vector3d>& x_cur,
                            const std::vector<double>& sigma, const Eigen::Isometry3d& initial,
                            const LorentzianParams& params = {});

// The same cost with the translation known: X''_i ~ R (X'_i - c), c = the new base origin in
// the previous base frame (the odometry's step), so T = [R | -R c]. `initial` supplies R's
// starting value. Same errors and fields as RegisterLorentzian.
RigidFit RegisterLorentzianRotation(const std::vector<Eigen::Vector3d>& x_prev,
                                    const std::vector<Eigen::Vector3d>& x_cur,
                                    const std::vector<double>& sigma, const Eigen::Vector3d& pivot,
                                    const Eigen::Matrix3d& initial,
                                    const LorentzianParams& params = {});

// Rotation angle about the vertical (z) axis of a rotation matrix: atan2(R10, R00).
double YawOf(const Eigen::Matrix3d& R);

}  // namespace epmap::localisation
