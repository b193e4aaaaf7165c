#include "perception/localisation/lorentzian_registration.h"

#include <Eigen/SVD>
#include <cmath>
#include <stdexcept>

namespace epmap::localisation {

void LorentzianParams::Validate() const {
  if (max_iterations < 1) throw std::invalid_argument("lorentzian: max_iterations must be >= 1");
  if (!(tolerance > 0)) throw std::invalid_argument("lorentzian: tolerance must be > 0");
  if (min_pairs < 3) throw std::invalid_argument("lorentzian: min_pairs must be >= 3");
  if (!(inlier_sigmas > 0)) throw std::invalid_argument("lorentzian: inlier_sigmas must be > 0");
}

double YawOf(const Eigen::Matrix3d& R) {
  return std::atan2(R(1, 0), R(0, 0));
}

double LorentzianCost(const std::vector<Eigen::Vector3d>& x_prev,
                      const std::vector<Eigen::Vector3d>& x_cur, const std::vector<double>& sigma,
                      const Eigen::Isometry3d& T) {
  double cost = 0;
  for (size_t i = 0; i < x_prev.size(); ++i) {
    const double r2 = (x_cur[i] - T * x_prev[i]).squaredNorm();
    cost += std::log1p(r2 / (sigma[i] * sigma[i]));
  }
  return cost;
}

namespace {

// Weighted absolute orientation: the (R, t) minimising sum w_i ||b_i - (R a_i + t)||^2, or
// with centred = false the R minimising sum w_i ||b_i - R a_i||^2 (t = 0).
// Returns false when the weighted points are degenerate (all on one line).
bool WeightedRigid(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                   const std::vector<double>& w, bool vertical_only, Eigen::Isometry3d* T,
                   bool centred = true) {
  double wsum = 0;
  Eigen::Vector3d ca = Eigen::Vector3d::Zero(), cb = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) {
    wsum += w[i];
    ca += w[i] * a[i];
    cb += w[i] * b[i];
  }
  if (!(wsum > 0)) return false;
  ca /= wsum;
  cb /= wsum;
  if (!centred) {
    ca.setZero();
    cb.setZero();
  }
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (vertical_only) {
    // Planar Kabsch on x, y: the angle maximising sum w (a x b)_z and (a . b)_xy.
    double s = 0, c = 0, spread = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      const Eigen::Vector2d p = (a[i] - ca).head<2>(), q = (b[i] - cb).head<2>();
      s += w[i] * (p.x() * q.y() - p.y() * q.x());
      c += w[i] * p.dot(q);
      spread += w[i] * p.squaredNorm();
    }
    if (!(spread > 1e-12 * wsum)) return false;
    R = Eigen::AngleAxisd(std::atan2(s, c), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  } else {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (size_t i = 0; i < a.size(); ++i) H += w[i] * (a[i] - ca) * (b[i] - cb).transpose();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Vector3d sv = svd.singularValues();
    if (!(sv(1) > 1e-9 * std::max(sv(0), 1e-300))) return false;  // points on a line
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
    R = svd.matrixV() * D * svd.matrixU().transpose();
  }
  T->setIdentity();
  T->linear() = R;
  T->translation() = cb - R * ca;
  return true;
}

// IRLS shared by both forms: a_i = X'_i (minus the pivot), fit b_i ~ R a_i (+ t if centred).
RigidFit Irls(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
              const std::vector<double>& sigma, const Eigen::Isometry3d& initial, bool centred,
              const LorentzianParams& params) {
  params.Validate();
  const auto& x_prev = a;
  const auto& x_cur = b;
  if (x_prev.size() != x_cur.size() || x_prev.size() != sigma.size()) {
    throw std::invalid_argument("RegisterLorentzian: point and sigma lists differ in length");
  }
  for (double s : sigma) {
    if (!(s > 0) || !std::isfinite(s)) {
      throw std::invalid_argument("RegisterLorentzian: every sigma must be positive and finite");
    }
  }
  RigidFit fit;
  fit.pairs = static_cast<int>(x_prev.size());
  fit.T = initial;
  if (fit.pairs < params.min_pairs) {
    fit.reason = "only " + std::to_string(fit.pairs) + " pairs (at least " +
                 std::to_string(params.min_pairs) + " needed)";
    fit.cost = LorentzianCost(x_prev, x_cur, sigma, fit.T);
    return fit;
  }
  std::vector<double> w(x_prev.size());
  for (fit.iterations = 1; fit.iterations <= params.max_iterations; ++fit.iterations) {
    for (size_t i = 0; i < x_prev.size(); ++i) {
      const double r2 = (x_cur[i] - fit.T * x_prev[i]).squaredNorm();
      w[i] = 1.0 / (sigma[i] * sigma[i] + r2);
    }
    Eigen::Isometry3d next;
    if (!WeightedRigid(x_prev, x_cur, w, params.vertical_axis_only, &next, centred)) {
      fit.reason = "degenerate point configuration (all points on one line)";
      fit.cost = LorentzianCost(x_prev, x_cur, sigma, fit.T);
      return fit;
    }
    const double change =
        (next.linear() - fit.T.linear()).norm() + (next.translation() - fit.T.translation()).norm();
    fit.T = next;
    if (change < params.tolerance) break;
  }
  fit.iterations = std::min(fit.iterations, params.max_iterations);
  fit.cost = LorentzianCost(x_prev, x_cur, sigma, fit.T);
  for (size_t i = 0; i < x_prev.size(); ++i) {
    if ((x_cur[i] - fit.T * x_prev[i]).norm() <= params.inlier_sigmas * sigma[i]) ++fit.inliers;
  }
  if (fit.inliers < params.min_pairs) {
    fit.reason = "only " + std::to_string(fit.inliers) + " inliers of " +
                 std::to_string(fit.pairs) + " pairs";
    return fit;
  }
  fit.ok = true;
  return fit;
}

}  // namespace

RigidFit RegisterLorentzian(const std::vector<Eigen::Vector3d>& x_prev,
                            const std::vector<Eigen::Vector3d>& x_cur,
                            const std::vector<double>& sigma, const Eigen::Isometry3d& initial,
                            const LorentzianParams& params) {
  return Irls(x_prev, x_cur, sigma, initial, true, params);
}

RigidFit RegisterLorentzianRotation(const std::vector<Eigen::Vector3d>& x_prev,
                                    const std::vector<Eigen::Vector3d>& x_cur,
                                    const std::vector<double>& sigma, const Eigen::Vector3d& pivot,
                                    const Eigen::Matrix3d& initial,
                                    const LorentzianParams& params) {
  std::vector<Eigen::Vector3d> moved(x_prev.size());
  for (size_t i = 0; i < x_prev.size(); ++i) moved[i] = x_prev[i] - pivot;
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  start.linear() = initial;
  RigidFit fit = Irls(moved, x_cur, sigma, start, false, params);
  // Back to T_cur_prev: X'' = R (X' - c) = R X' - R c.
  fit.T.translation() = -(fit.T.linear() * pivot);
  return fit;
}

}  // namespace epmap::localisation
