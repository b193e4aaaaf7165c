#include <gtest/gtest.h>

#include <numbers>
#include <random>

#include "perception/localisation/lorentzian_registration.h"

namespace epmap {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

struct Problem {
  std::vector<Eigen::Vector3d> a, b;
  std::vector<double> sigma;
  Eigen::Isometry3d truth;
};

// Points 1-8 m around the robot, moved by a known rotation (mostly yaw) and translation, with
// noise; a share of the pairs replaced by gross outliers (wrong tracks).
Problem MakeProblem(double outlier_share, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, 0.01);
  Problem p;
  p.truth = Eigen::Isometry3d::Identity();
  p.truth.linear() = (Eigen::AngleAxisd(12 * kDeg, Eigen::Vector3d::UnitZ()) *
                      Eigen::AngleAxisd(1 * kDeg, Eigen::Vector3d::UnitX()))
                         .toRotationMatrix();
  p.truth.translation() = Eigen::Vector3d(-0.3, 0.05, 0.01);
  for (int i = 0; i < 120; ++i) {
    const Eigen::Vector3d x(4 + 3.5 * u(rng), 4 * u(rng), 1 + 0.8 * u(rng));
    Eigen::Vector3d y = p.truth * x + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    if (i < outlier_share * 120) y += Eigen::Vector3d(2 * u(rng), 2 * u(rng), 0.5 * u(rng));
    p.a.push_back(x);
    p.b.push_back(y);
    p.sigma.push_back(0.03);
  }
  return p;
}

double YawError(const Eigen::Isometry3d& fit, const Eigen::Isometry3d& truth) {
  return std::abs(localisation::YawOf(fit.linear()) - localisation::YawOf(truth.linear()));
}

TEST(Lorentzian, RecoversAKnownRotationDespiteOutliers) {
  const Problem p = MakeProblem(0.3, 7);
  const auto fit =
      localisation::RegisterLorentzian(p.a, p.b, p.sigma, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(fit.ok) << fit.reason;
  EXPECT_LT(YawError(fit.T, p.truth), 0.1 * kDeg);
  EXPECT_LT((fit.T.translation() - p.truth.translation()).norm(), 0.01);
  EXPECT_LT(fit.cost,
            localisation::LorentzianCost(p.a, p.b, p.sigma, Eigen::Isometry3d::Identity()));
  EXPECT_GE(fit.inliers, 80);

  // Plain least squares (one iteration with equal weights, i.e. huge sigmas) is pulled away
  // by the same outliers: the robust cost is what makes the difference.
  localisation::LorentzianParams one;
  one.max_iterations = 1;
  const std::vector<double> flat(p.a.size(), 1e6);
  const auto ls =
      localisation::RegisterLorentzian(p.a, p.b, flat, Eigen::Isometry3d::Identity(), one);
  EXPECT_GT(YawError(ls.T, p.truth), 5 * YawError(fit.T, p.truth));
}

TEST(Lorentzian, VerticalAxisOnlyGivesTheYaw) {
  Problem p = MakeProblem(0.2, 3);
  localisation::LorentzianParams planar;
  planar.vertical_axis_only = true;
  const auto fit =
      localisation::RegisterLorentzian(p.a, p.b, p.sigma, Eigen::Isometry3d::Identity(), planar);
  ASSERT_TRUE(fit.ok) << fit.reason;
  EXPECT_LT(YawError(fit.T, p.truth), 0.3 * kDeg);  // the 1 degree of roll is not modelled
  EXPECT_NEAR(fit.T.linear()(2, 2), 1.0, 1e-12);
}

TEST(Lorentzian, RefusesTooFewOrDegeneratePairs) {
  const Problem p = MakeProblem(0.0, 1);
  std::vector<Eigen::Vector3d> a(p.a.begin(), p.a.begin() + 4), b(p.b.begin(), p.b.begin() + 4);
  const auto few = localisation::RegisterLorentzian(a, b, {0.03, 0.03, 0.03, 0.03},
                                                    Eigen::Isometry3d::Identity());
  EXPECT_FALSE(few.ok);
  EXPECT_NE(few.reason.find("pairs"), std::string::npos);

  std::vector<Eigen::Vector3d> line_a, line_b;
  for (int i = 0; i < 10; ++i) {
    line_a.emplace_back(i, 0, 0);
    line_b.emplace_back(i, 0, 0);
  }
  const auto line = localisation::RegisterLorentzian(line_a, line_b, std::vector<double>(10, 0.03),
                                                     Eigen::Isometry3d::Identity());
  EXPECT_FALSE(line.ok);
  EXPECT_NE(line.reason.find("line"), std::string::npos);

  EXPECT_THROW(localisation::RegisterLorentzian(a, b, {0.03}, Eigen::Isometry3d::Identity()),
               std::invalid_argument);
  EXPECT_THROW(localisation::RegisterLorentzian(a, b, {0.03, 0.03, 0.0, 0.03},
                                                Eigen::Isometry3d::Identity()),
               std::invalid_argument);
}

}  // namespace
}  // namespace epmap
