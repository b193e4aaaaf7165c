#include "perception/calibration/se3_fit.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlopt.hpp>

namespace epmap::calibration {

namespace {

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Vector3d Vee(const Eigen::Matrix3d& m) {
  return {m(2, 1), m(0, 2), m(1, 0)};
}

std::string Cm(double metres) {
  char buf[32];
  if (metres >= 0.01) {
    std::snprintf(buf, sizeof buf, "%.1f cm", metres * 100.0);
  } else {
    std::snprintf(buf, sizeof buf, "%.2f mm", metres * 1000.0);
  }
  return buf;
}

double Median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

void CheckInput(const Eigen::Matrix3Xd& xa, const Eigen::Matrix3Xd& xb) {
  if (xa.cols() != xb.cols()) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           "X_A has " + std::to_string(xa.cols()) + " points but X_B has " +
                               std::to_string(xb.cols()) + ": they must be paired");
  }
  for (Eigen::Index i = 0; i < xa.cols(); ++i) {
    if (!xa.col(i).allFinite() || !xb.col(i).allFinite()) {
      throw CalibrationError(ErrorCode::kInvalidInput,
                             "sample " + std::to_string(i) +
                                 " has a non-finite coordinate (NaN or inf): drop it first");
    }
  }
}

Eigen::Matrix3Xd Masked(const Eigen::Matrix3Xd& m, const std::vector<uint8_t>& mask) {
  Eigen::Index n = 0;
  for (auto v : mask) n += v ? 1 : 0;
  Eigen::Matrix3Xd out(3, n);
  Eigen::Index j = 0;
  for (Eigen::Index i = 0; i < m.cols(); ++i) {
    if (mask[static_cast<size_t>(i)]) out.col(j++) = m.col(i);
  }
  return out;
}

struct SolveContext {
  const Se3Objective* objective;
  const ProgressCallback* progress;
  double fraction;
  double metric_scale;  // L^2: normalised cost -> m^2
  int evaluations = 0;
};

double NloptObjective(unsigned n, const double* x, double* grad, void* data) {
  auto* ctx = static_cast<SolveContext*>(data);
  (void)n;
  const double f = ctx->objective->Evaluate(x, grad);
  ++ctx->evaluations;
  if (*ctx->progress && ctx->evaluations % 8 == 1) {
    Progress p{"se3-fit", static_cast<uint64_t>(ctx->evaluations), f * ctx->metric_scale,
               ctx->fraction};
    if (!(*ctx->progress)(p)) throw nlopt::forced_stop();
  }
  return f;
}

}  // namespace

Eigen::Matrix3d ExpSo3(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  if (theta < 1e-12) return Eigen::Matrix3d::Identity() + Hat(w);
  return Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
}

Eigen::Matrix3d RightJacobianSo3(const Eigen::Vector3d& w) {
  // J_r(w) = I - (1 - cos t)/t^2 [w]x + (t - sin t)/t^3 [w]x^2, series near t = 0.
  const double t2 = w.squaredNorm();
  const double t = std::sqrt(t2);
  double a, b;
  if (t < 1e-4) {
    a = 0.5 - t2 / 24.0;
    b = 1.0 / 6.0 - t2 / 120.0;
  } else {
    a = (1.0 - std::cos(t)) / t2;
    b = (t - std::sin(t)) / (t2 * t);
  }
  const Eigen::Matrix3d h = Hat(w);
  return Eigen::Matrix3d::Identity() - a * h + b * h * h;
}

Se3Objective::Se3Objective(const Eigen::Matrix3Xd& xa, const Eigen::Matrix3Xd& xb,
                           const std::vector<uint8_t>* mask, bool with_scale)
    : with_scale_(with_scale) {
  const auto use = [&](Eigen::Index i) { return !mask || (*mask)[static_cast<size_t>(i)] != 0; };
  double n = 0;
  mean_a_.setZero();
  mean_b_.setZero();
  for (Eigen::Index i = 0; i < xa.cols(); ++i) {
    if (!use(i)) continue;
    mean_a_ += xa.col(i);
    mean_b_ += xb.col(i);
    n += 1;
  }
  if (n == 0) throw CalibrationError(ErrorCode::kDegenerate, "no samples to fit");
  mean_a_ /= n;
  mean_b_ /= n;
  caa_.setZero();
  cba_.setZero();
  cbb_ = 0;
  for (Eigen::Index i = 0; i < xa.cols(); ++i) {
    if (!use(i)) continue;
    const Eigen::Vector3d a = xa.col(i) - mean_a_;
    const Eigen::Vector3d b = xb.col(i) - mean_b_;
    caa_ += a * a.transpose();
    cba_ += b * a.transpose();
    cbb_ += b.squaredNorm();
  }
  length_ = std::sqrt(caa_.trace() / n);
  if (!(length_ > 0)) length_ = 1.0;
  const double norm = n * length_ * length_;
  caa_ /= norm;
  cba_ /= norm;
  cbb_ /= norm;
}

double Se3Objective::Evaluate(const double* x, double* grad) const {
  const Eigen::Vector3d w(x[0], x[1], x[2]);
  const Eigen::Vector3d tau(x[3], x[4], x[5]);
  const Eigen::Matrix3d r = anchor_ * ExpSo3(w);
  Eigen::Vector3d s = Eigen::Vector3d::Ones();
  if (with_scale_) s = Eigen::Vector3d(x[6], x[7], x[8]).array().exp();
  const Eigen::Matrix3d m = r * s.asDiagonal();
  const Eigen::Matrix3d m_caa = m * caa_;
  // Eq. 9 through the moments: |b~ - M a~ - tau|^2 averaged (cross terms with tau vanish).
  const double f =
      cbb_ - 2.0 * m.cwiseProduct(cba_).sum() + m_caa.cwiseProduct(m).sum() + tau.squaredNorm();
  if (grad) {
    const Eigen::Matrix3d g = 2.0 * (m_caa - cba_);  // df/dM
    const Eigen::Matrix3d df_dr = g * s.asDiagonal();
    const Eigen::Matrix3d b = r.transpose() * df_dr;
    // dR = R [J_r dw]x  =>  df = <df/dR, R [v]x> = v . vee(B - B^T), B = R^T df/dR.
    const Eigen::Vector3d gw = RightJacobianSo3(w).transpose() * Vee(b - b.transpose());
    for (int i = 0; i < 3; ++i) {
      grad[i] = gw(i);
      grad[3 + i] = 2.0 * tau(i);
    }
    if (with_scale_) {
      const Eigen::Matrix3d rt_g = r.transpose() * g;
      for (int k = 0; k < 3; ++k) grad[6 + k] = s(k) * rt_g(k, k);  // ds/dsigma = s
    }
  }
  return f;
}

LinearExpert Se3Objective::Decode(const double* x) const {
  LinearExpert t;
  t.rotation = anchor_ * ExpSo3(Eigen::Vector3d(x[0], x[1], x[2]));
  // Keep it exactly orthonormal after many re-anchorings.
  t.rotation = Eigen::Quaterniond(t.rotation).normalized().toRotationMatrix();
  if (with_scale_) t.scale = Eigen::Vector3d(x[6], x[7], x[8]).array().exp();
  const Eigen::Vector3d tau(x[3], x[4], x[5]);
  t.translation = mean_b_ + length_ * tau - t.Linear() * mean_a_;
  return t;
}

void Se3Objective::Encode(const LinearExpert& t, double* x) {
  anchor_ = t.rotation;
  const Eigen::Vector3d tau = (t.translation + t.Linear() * mean_a_ - mean_b_) / length_;
  for (int i = 0; i < 3; ++i) {
    x[i] = 0.0;
    x[3 + i] = tau(i);
    if (with_scale_) x[6 + i] = std::log(t.scale(i));
  }
}

void CheckObservability(const Eigen::Matrix3Xd& xa, const Se3FitParams& params,
                        const std::string& what) {
  const Eigen::Index need = params.anisotropic_scale ? 4 : 3;
  if (xa.cols() < need) {
    throw CalibrationError(ErrorCode::kDegenerate,
                           what + ": " + std::to_string(xa.cols()) + " sample(s), but " +
                               (params.anisotropic_scale ? "se3-scale needs at least 4 "
                                                           "non-coplanar samples"
                                                         : "SE(3) needs at least 3 non-collinear "
                                                           "samples"));
  }
  const PointSpread s = MeasureSpread(xa);
  if (s.sigma(0) < params.min_spread_m) {
    throw CalibrationError(ErrorCode::kDegenerate,
                           what + " are all at one point (spread " + Cm(s.sigma(0)) +
                               "): rotation cannot be determined; collect samples over the "
                               "workspace");
  }
  if (s.sigma(1) < std::max(params.line_ratio * s.sigma(0), params.min_spread_m)) {
    throw CalibrationError(ErrorCode::kDegenerate,
                           what + " lie on a line (spread " + Cm(s.sigma(0)) + " along it, " +
                               Cm(s.sigma(1)) +
                               " across): the rotation about that line cannot be determined; "
                               "add samples off the line");
  }
  if (params.anisotropic_scale &&
      s.sigma(2) < std::max(params.plane_ratio * s.sigma(0), params.min_spread_m)) {
    throw CalibrationError(ErrorCode::kDegenerate,
                           what + " lie on a plane (thickness " + Cm(s.sigma(2)) +
                               " against an extent of " + Cm(s.sigma(0)) +
                               "): the scale along its normal cannot be determined; use method "
                               "se3, or add samples off the plane");
  }
}

LinearExpert UmeyamaSe3(const Eigen::Matrix3Xd& xa, const Eigen::Matrix3Xd& xb) {
  CheckInput(xa, xb);
  CheckObservability(xa, Se3FitParams{});
  const Eigen::Matrix4d h = Eigen::umeyama(xa, xb, false);
  LinearExpert t;
  t.rotation = h.topLeftCorner<3, 3>();
  t.translation = h.topRightCorner<3, 1>();
  return t;
}

Se3FitResult FitSe3(const Eigen::Matrix3Xd& xa, const Eigen::Matrix3Xd& xb,
                    const Se3FitParams& params, const ProgressCallback& progress) {
  CheckInput(xa, xb);
  const auto n = static_cast<size_t>(xa.cols());
  Se3FitResult result;
  result.inlier.assign(n, 1);
  CheckObservability(xa, params);

  LinearExpert current;
  if (params.init == Se3FitParams::Init::kUmeyama) {
    const Eigen::Matrix4d h = Eigen::umeyama(xa, xb, false);
    current.rotation = h.topLeftCorner<3, 3>();
    current.translation = h.topRightCorner<3, 1>();
  }

  const int max_rounds = params.outliers.enabled ? std::max(1, params.outliers.max_rounds) : 1;
  std::vector<double> residual(n);
  for (int round = 1; round <= max_rounds; ++round) {
    if (round > 1) CheckObservability(Masked(xa, result.inlier), params, "the inlier samples");
    Se3Objective objective(xa, xb, &result.inlier, params.anisotropic_scale);
    std::vector<double> x(static_cast<size_t>(objective.dimension()));
    objective.Encode(current, x.data());
    SolveContext ctx{&objective, &progress,
                     static_cast<double>(round - 1) / static_cast<double>(max_rounds),
                     objective.length_scale() * objective.length_scale()};
    double f = 0;
    for (int recentre = 0; recentre <= params.max_recentres; ++recentre) {
      nlopt::opt opt(nlopt::LD_LBFGS, static_cast<unsigned>(objective.dimension()));
      opt.set_min_objective(NloptObjective, &ctx);
      opt.set_ftol_rel(params.ftol_rel);
      opt.set_xtol_abs(params.xtol_abs);
      opt.set_maxeval(params.max_evaluations);
      try {
        opt.optimize(x, f);
      } catch (const nlopt::roundoff_limited&) {
        // L-BFGS reached the precision floor: x holds the best point found, which is the answer.
      } catch (const nlopt::forced_stop&) {
        throw CalibrationError(
            ErrorCode::kCancelled,
            "se3 fit cancelled after " + std::to_string(ctx.evaluations) + " evaluations");
      } catch (const std::exception& e) {
        throw CalibrationError(ErrorCode::kNotConverged,
                               std::string("NLopt L-BFGS failed on the se3 fit: ") + e.what());
      }
      f = objective.Evaluate(x.data(), nullptr);
      if (!std::isfinite(f)) {
        throw CalibrationError(ErrorCode::kNotConverged, "se3 fit diverged (non-finite cost)");
      }
      current = objective.Decode(x.data());
      const double step = Eigen::Vector3d(x[0], x[1], x[2]).norm();
      if (step < params.recentre_above_rad) break;
      objective.Encode(current, x.data());  // re-centre the chart on the new estimate
    }
    result.stats.evaluations += ctx.evaluations;
    result.stats.rounds = round;
    result.stats.cost_m2 = f * ctx.metric_scale;

    if (!params.outliers.enabled) break;
    for (size_t i = 0; i < n; ++i) {
      const auto c = static_cast<Eigen::Index>(i);
      residual[i] = (xb.col(c) - current.Apply(xa.col(c))).norm();
    }
    const double med = Median(residual);
    std::vector<double> dev(n);
    for (size_t i = 0; i < n; ++i) dev[i] = std::abs(residual[i] - med);
    const double mad = Median(dev);
    const double threshold =
        std::max(med + params.outliers.k * 1.4826 * mad, params.outliers.floor_m);
    std::vector<uint8_t> next(n);
    size_t kept = 0;
    for (size_t i = 0; i < n; ++i) {
      next[i] = residual[i] <= threshold ? 1 : 0;
      kept += next[i];
    }
    if (next == result.inlier || round == max_rounds) break;
    if (static_cast<double>(n - kept) >
        params.outliers.max_rejected_share * static_cast<double>(n)) {
      throw CalibrationError(
          ErrorCode::kDegenerate,
          std::to_string(n - kept) + " of " + std::to_string(n) +
              " samples are outliers (residual above " + Cm(threshold) +
              "): the data does not follow one rigid map (mis-paired samples, or a "
              "workspace-dependent error: try the mixture)");
    }
    result.inlier = std::move(next);
  }

  ReportProgress(progress, {"se3-fit", static_cast<uint64_t>(result.stats.evaluations),
                            result.stats.cost_m2, 1.0});

  const Eigen::Matrix3Xd inlier_a = Masked(xa, result.inlier);
  const Eigen::Matrix3Xd inlier_b = Masked(xb, result.inlier);
  std::vector<double> d(static_cast<size_t>(inlier_a.cols()));
  for (Eigen::Index i = 0; i < inlier_a.cols(); ++i) {
    d[static_cast<size_t>(i)] = (inlier_b.col(i) - current.Apply(inlier_a.col(i))).norm();
  }
  result.stats.samples = n;
  result.stats.inliers = static_cast<size_t>(inlier_a.cols());
  result.stats.rejected = n - result.stats.inliers;
  result.stats.inlier_errors = Summarise(std::move(d));
  current.centroid = inlier_a.rowwise().mean();
  const Eigen::Matrix3Xd centred = inlier_a.colwise() - current.centroid;
  current.covariance = centred * centred.transpose() / static_cast<double>(inlier_a.cols());
  result.transform = current;
  return result;
}

}  // namespace epmap::calibration
