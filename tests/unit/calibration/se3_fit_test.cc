// Eq. 9 (SE(3) and se3-scale fits with NLopt): agreement with the closed form, the analytic
// gradient, outlier rejection, and every degenerate input refused with a reason.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "perception/calibration/se3_fit.h"
#include "tests/unit/calibration/synthetic_eye_hand.h"

namespace epmap::calibration {
namespace {

// Points in a 3-D blob, mapped by a known H plus noise.
struct Pairs {
  Eigen::Matrix3Xd a, b;
};

Pairs MakePairs(int n, const Eigen::Matrix3d& r, const Eigen::Vector3d& s, const Eigen::Vector3d& t,
                double noise, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Pairs p;
  p.a.resize(3, n);
  p.b.resize(3, n);
  for (int i = 0; i < n; ++i) {
    p.a.col(i) = Eigen::Vector3d(-0.3, 0.0, 0.1) +
                 Eigen::Vector3d(0.12 * g(rng), 0.10 * g(rng), 0.08 * g(rng));
    p.b.col(i) =
        r * s.asDiagonal() * p.a.col(i) + t + noise * Eigen::Vector3d(g(rng), g(rng), g(rng));
  }
  return p;
}

double RmsDifference(const LinearExpert& x, const LinearExpert& y, const Eigen::Matrix3Xd& a) {
  double sum = 0;
  for (Eigen::Index i = 0; i < a.cols(); ++i) {
    sum += (x.Apply(a.col(i)) - y.Apply(a.col(i))).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(a.cols()));
}

Eigen::Matrix3d Rot(double angle, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

ErrorCode CodeOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const CalibrationError& e) {
    EXPECT_FALSE(std::string(e.what()).empty());
    return e.code();
  }
  ADD_FAILURE() << "no CalibrationError thrown";
  return ErrorCode::kNotConverged;
}

TEST(Se3Fit, EqualsUmeyamaFromUmeyamaAndFromIdentity) {
  const Pairs p =
      MakePairs(300, Rot(0.4, {1, 2, 3}), Eigen::Vector3d::Ones(), {0.05, -0.2, 0.3}, 0.003, 1);
  const LinearExpert oracle = UmeyamaSe3(p.a, p.b);
  Se3FitParams params;
  params.outliers.enabled = false;
  for (auto init : {Se3FitParams::Init::kUmeyama, Se3FitParams::Init::kIdentity}) {
    params.init = init;
    const Se3FitResult fit = FitSe3(p.a, p.b, params);
    EXPECT_LT(RmsDifference(fit.transform, oracle, p.a), 1e-6);
    if (init == Se3FitParams::Init::kIdentity) {
      EXPECT_GE(fit.stats.evaluations, 5);  // NLopt did the work, not the closed form
    }
  }
}

TEST(Se3Fit, FromIdentityRecoversLargeRotations) {
  // 170 degrees: far from the identity start, the chart is re-centred on the way.
  for (double angle : {1.5, 2.97}) {
    const Pairs p = MakePairs(200, Rot(angle, {-1, 0.5, 0.2}), Eigen::Vector3d::Ones(),
                              {0.3, 0.1, -0.2}, 0.001, 2);
    Se3FitParams params;
    params.init = Se3FitParams::Init::kIdentity;
    params.outliers.enabled = false;
    const Se3FitResult fit = FitSe3(p.a, p.b, params);
    EXPECT_LT(RmsDifference(fit.transform, UmeyamaSe3(p.a, p.b), p.a), 1e-6) << angle;
  }
}

TEST(Se3Fit, AnalyticGradientMatchesFiniteDifferences) {
  const Pairs p = MakePairs(80, Rot(0.3, {0, 1, 1}), {1.05, 0.97, 1.02}, {0.1, 0, 0}, 0.01, 3);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  for (bool scale : {false, true}) {
    Se3Objective objective(p.a, p.b, nullptr, scale);
    LinearExpert anchor;
    anchor.rotation = Rot(0.7, {1, -1, 0.3});
    std::vector<double> x(static_cast<size_t>(objective.dimension()));
    objective.Encode(anchor, x.data());
    for (int trial = 0; trial < 5; ++trial) {
      for (double& v : x) v = u(rng);  // away from w = 0, where J_r matters
      std::vector<double> grad(x.size());
      objective.Evaluate(x.data(), grad.data());
      for (size_t k = 0; k < x.size(); ++k) {
        const double h = 1e-6;
        std::vector<double> xp = x, xm = x;
        xp[k] += h;
        xm[k] -= h;
        const double fd =
            (objective.Evaluate(xp.data(), nullptr) - objective.Evaluate(xm.data(), nullptr)) /
            (2 * h);
        EXPECT_NEAR(grad[k], fd, 1e-6 * std::max(1.0, std::abs(fd)))
            << "scale " << scale << " parameter " << k;
      }
    }
  }
}

TEST(Se3Fit, MomentObjectiveEqualsTheDirectSum) {
  const Pairs p = MakePairs(50, Rot(0.2, {1, 0, 0}), {1.1, 0.9, 1.0}, {0.02, 0.03, 0.04}, 0.01, 5);
  Se3Objective objective(p.a, p.b, nullptr, true);
  const std::vector<double> x = {0.1, -0.2, 0.05, 0.3, -0.1, 0.2, 0.05, -0.03, 0.01};
  const LinearExpert h = objective.Decode(x.data());
  double direct = 0;
  for (Eigen::Index i = 0; i < p.a.cols(); ++i)
    direct += (p.b.col(i) - h.Apply(p.a.col(i))).squaredNorm();
  direct /= static_cast<double>(p.a.cols());
  const double l = objective.length_scale();
  EXPECT_NEAR(objective.Evaluate(x.data(), nullptr) * l * l, direct, 1e-12);
}

TEST(Se3Fit, ScaleVariantRecoversAnisotropicScale) {
  const Eigen::Vector3d s(1.03, 0.96, 1.06);
  const Eigen::Matrix3d r = Rot(0.25, {0.2, 1, -0.4});
  const Pairs p = MakePairs(400, r, s, {0.01, 0.02, -0.03}, 0.0005, 6);
  Se3FitParams params;
  params.anisotropic_scale = true;
  params.init = Se3FitParams::Init::kIdentity;
  const Se3FitResult fit = FitSe3(p.a, p.b, params);
  EXPECT_LT((fit.transform.scale - s).norm(), 2e-3);
  EXPECT_LT(Eigen::AngleAxisd(fit.transform.rotation.transpose() * r).angle(), 1e-3);
  // And it beats the rigid fit on scaled data.
  params.anisotropic_scale = false;
  EXPECT_LT(fit.stats.inlier_errors.rmse_m, FitSe3(p.a, p.b, params).stats.inlier_errors.rmse_m);
}

TEST(Se3Fit, RejectsGrossOutliersAndReportsThem) {
  Pairs p = MakePairs(400, Rot(0.3, {1, 1, 0}), Eigen::Vector3d::Ones(), {0.1, 0.2, 0.0}, 0.002, 7);
  const LinearExpert truth = UmeyamaSe3(p.a, p.b);
  for (int i = 0; i < 400; i += 25) p.b.col(i) += Eigen::Vector3d(0.10, -0.08, 0.12);  // 16
  Se3FitParams params;
  const Se3FitResult fit = FitSe3(p.a, p.b, params);
  EXPECT_EQ(fit.stats.rejected, 16u);
  for (int i = 0; i < 400; i += 25) EXPECT_EQ(fit.inlier[static_cast<size_t>(i)], 0);
  EXPECT_LT(RmsDifference(fit.transform, truth, p.a), 5e-4);
  params.outliers.enabled = false;
  EXPECT_GT(RmsDifference(FitSe3(p.a, p.b, params).transform, truth, p.a), 2e-3);
}

TEST(Se3Fit, CleanDataLosesNoSampleToTheOutlierRule) {
  const Pairs p = MakePairs(500, Rot(0.1, {0, 0, 1}), Eigen::Vector3d::Ones(), {0, 0, 0}, 0.002, 8);
  EXPECT_EQ(FitSe3(p.a, p.b).stats.rejected, 0u);
}

TEST(Se3Fit, RefusesTooFewSamples) {
  const Pairs p =
      MakePairs(2, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Ones(), {0, 0, 0}, 0, 9);
  EXPECT_EQ(CodeOf([&] { FitSe3(p.a, p.b); }), ErrorCode::kDegenerate);
  EXPECT_EQ(CodeOf([&] { FitSe3(Eigen::Matrix3Xd(3, 0), Eigen::Matrix3Xd(3, 0)); }),
            ErrorCode::kDegenerate);
}

TEST(Se3Fit, RefusesCollinearSamples) {
  Eigen::Matrix3Xd a(3, 30), b(3, 30);
  for (int i = 0; i < 30; ++i) {
    a.col(i) = Eigen::Vector3d(0.1, 0.2, 0.3) + 0.01 * i * Eigen::Vector3d(1, 2, -1).normalized();
    a.col(i) += Eigen::Vector3d(1e-6 * (i % 3), 0, 0);  // noise far below the line's length
    b.col(i) = a.col(i) + Eigen::Vector3d(0.01, 0, 0);
  }
  try {
    FitSe3(a, b);
    FAIL() << "collinear samples accepted";
  } catch (const CalibrationError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kDegenerate);
    EXPECT_NE(std::string(e.what()).find("line"), std::string::npos) << e.what();
  }
  EXPECT_EQ(CodeOf([&] { UmeyamaSe3(a, b); }), ErrorCode::kDegenerate);
}

TEST(Se3Fit, RefusesNanAndMismatchedInput) {
  Pairs p = MakePairs(20, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Ones(), {0, 0, 0}, 0, 10);
  p.a(1, 7) = std::nan("");
  EXPECT_EQ(CodeOf([&] { FitSe3(p.a, p.b); }), ErrorCode::kInvalidInput);
  const Pairs q =
      MakePairs(20, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Ones(), {0, 0, 0}, 0, 11);
  EXPECT_EQ(CodeOf([&] { FitSe3(q.a, q.b.leftCols(19)); }), ErrorCode::kInvalidInput);
}

TEST(Se3Fit, PlanarDataIsFineForSe3ButRefusedForScale) {
  Pairs p = MakePairs(100, Rot(0.2, {1, 0, 0}), Eigen::Vector3d::Ones(), {0, 0.1, 0}, 0.0, 12);
  const Eigen::Matrix3d r = Rot(0.2, {1, 0, 0});
  for (Eigen::Index i = 0; i < p.a.cols(); ++i) {
    p.a(2, i) = 0.1;  // all on the plane z = 0.1
    p.b.col(i) = r * p.a.col(i) + Eigen::Vector3d(0, 0.1, 0);
  }
  const Se3FitResult fit = FitSe3(p.a, p.b);
  EXPECT_LT(Eigen::AngleAxisd(fit.transform.rotation.transpose() * r).angle(), 1e-8);
  Se3FitParams scale;
  scale.anisotropic_scale = true;
  try {
    FitSe3(p.a, p.b, scale);
    FAIL() << "planar data accepted for se3-scale";
  } catch (const CalibrationError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kDegenerate);
    EXPECT_NE(std::string(e.what()).find("plane"), std::string::npos) << e.what();
  }
}

TEST(Se3Fit, CancelledByTheProgressCallback) {
  const Pairs p =
      MakePairs(100, Rot(1.0, {1, 0, 0}), Eigen::Vector3d::Ones(), {0, 0, 0}, 0.001, 13);
  Se3FitParams params;
  params.init = Se3FitParams::Init::kIdentity;
  int calls = 0;
  const auto cancel = [&](const Progress& pr) {
    EXPECT_GE(pr.fraction, 0.0);
    EXPECT_LE(pr.fraction, 1.0);
    EXPECT_TRUE(std::isfinite(pr.cost));
    return ++calls < 2;
  };
  EXPECT_EQ(CodeOf([&] { FitSe3(p.a, p.b, params, cancel); }), ErrorCode::kCancelled);
  // A callback that never cancels sees the fit through to fraction 1.
  double last = 0;
  FitSe3(p.a, p.b, params, [&](const Progress& pr) {
    last = pr.fraction;
    return true;
  });
  EXPECT_DOUBLE_EQ(last, 1.0);
}

TEST(So3, RightJacobianIsTheDerivativeOfExp) {
  const Eigen::Vector3d w(0.4, -0.9, 1.3), d(1e-7, -2e-7, 0.5e-7);
  // Exp(w + d) ~= Exp(w) Exp(J_r(w) d)
  const Eigen::Matrix3d lhs = ExpSo3(w + d);
  const Eigen::Matrix3d rhs = ExpSo3(w) * ExpSo3(RightJacobianSo3(w) * d);
  EXPECT_LT((lhs - rhs).norm(), 1e-12);
}

}  // namespace
}  // namespace epmap::calibration
