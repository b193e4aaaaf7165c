// Eq. 10 (mixture of SE(3) experts): k-means, the weights, beating one SE(3) on a curved error
// field, cross-validated K, and K too large for the data refused with a reason.

#include <gtest/gtest.h>

#include <cmath>

#include "perception/calibration/eye_hand_calibration.h"
#include "perception/calibration/mixture.h"
#include "tests/unit/calibration/synthetic_eye_hand.h"

namespace epmap::calibration {
namespace {

using testing::MakeEyeHandSamples;
using testing::SyntheticEyeHandParams;

struct Split {
  std::vector<EyeHandSample> train, test;
};

Split SplitPaths(const std::vector<EyeHandSample>& all, size_t train_paths) {
  const auto names = PathNames(all);
  const std::vector<std::string> test(names.begin() + static_cast<std::ptrdiff_t>(train_paths),
                                      names.end());
  return {SelectPaths(all, test, false), SelectPaths(all, test, true)};
}

TEST(KMeans, DeterministicGivenTheSeedAndFindsSeparatedClusters) {
  Eigen::Matrix3Xd p(3, 300);
  std::mt19937_64 rng(1);
  std::normal_distribution<double> g(0, 0.01);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d c = i < 100
                                  ? Eigen::Vector3d(0, 0, 0)
                                  : (i < 200 ? Eigen::Vector3d(1, 0, 0) : Eigen::Vector3d(0, 1, 0));
    p.col(i) = c + Eigen::Vector3d(g(rng), g(rng), g(rng));
  }
  const KMeansResult a = KMeans(p, 3, 42);
  const KMeansResult b = KMeans(p, 3, 42);
  EXPECT_EQ(a.assignment, b.assignment);
  EXPECT_EQ(a.centres, b.centres);
  for (int blob = 0; blob < 3; ++blob) {
    for (int i = blob * 100; i < blob * 100 + 100; ++i) {
      EXPECT_EQ(a.assignment[static_cast<size_t>(i)],
                a.assignment[static_cast<size_t>(blob * 100)]);
    }
  }
  EXPECT_NE(a.assignment[0], a.assignment[100]);
  EXPECT_NE(a.assignment[100], a.assignment[200]);
  EXPECT_THROW(KMeans(p, 301, 1), CalibrationError);
}

TEST(Mixture, WeightsAreNormalisedAndSafeFarAway) {
  std::vector<LinearExpert> experts(2);
  experts[0].centroid = {0, 0, 0};
  experts[1].centroid = {1, 0, 0};
  experts[0].covariance = experts[1].covariance = 0.01 * Eigen::Matrix3d::Identity();
  experts[1].translation = {0, 0, 1};
  const EyeHandModel m(EyeHandMethod::kMixture, experts);
  const Eigen::VectorXd mid = m.Weights({0.5, 0, 0});
  EXPECT_NEAR(mid.sum(), 1.0, 1e-12);
  EXPECT_NEAR(mid(0), 0.5, 1e-12);
  // 100 m away every exp(-d^2) underflows to 0; the max-shift keeps the weights defined.
  const Eigen::VectorXd far = m.Weights({100, 0, 0});
  EXPECT_TRUE(far.allFinite());
  EXPECT_NEAR(far.sum(), 1.0, 1e-12);
  EXPECT_NEAR(far(1), 1.0, 1e-12);
  EXPECT_TRUE(m.Apply(Eigen::Vector3d(-100, 3, 0)).allFinite());
}

TEST(Mixture, BeatsOneSe3OnACurvedErrorField) {
  const Split s = SplitPaths(MakeEyeHandSamples({}), 15);
  EyeHandCalibrationParams se3;
  const auto single = CalibrateEyeHand(s.train, s.test, se3);
  EyeHandCalibrationParams mix;
  mix.method = EyeHandMethod::kMixture;
  const auto mixture = CalibrateEyeHand(s.train, s.test, mix);
  EXPECT_EQ(mixture.errors.experts, 4);
  EXPECT_GT(single.errors.initial.mean_m, 0.03);  // the field is a few cm
  EXPECT_LT(single.errors.test.mean_m, single.errors.initial.mean_m / 2);
  EXPECT_LT(mixture.errors.test.mean_m, 0.85 * single.errors.test.mean_m)
      << "mixture " << mixture.errors.test.mean_m << " single " << single.errors.test.mean_m;
  // On a purely rigid field the mixture has nothing to add: both reach the noise floor.
  SyntheticEyeHandParams rigid;
  rigid.curvature = 0;
  const Split r = SplitPaths(MakeEyeHandSamples(rigid), 15);
  EXPECT_LT(CalibrateEyeHand(r.train, r.test, se3).errors.test.rmse_m, 0.004);
  EXPECT_LT(CalibrateEyeHand(r.train, r.test, mix).errors.test.rmse_m, 0.004);
}

TEST(Mixture, CrossValidationChoosesAFeasibleK) {
  const Split s = SplitPaths(MakeEyeHandSamples({}), 15);
  MixtureParams params;
  params.experts = 0;
  params.max_experts = 5;
  const MixtureFitResult fit = FitMixture(s.train, params);
  ASSERT_EQ(fit.cross_validation.size(), 5u);
  const int k = static_cast<int>(fit.model.experts().size());
  double best = 1e9;
  for (const auto& score : fit.cross_validation) {
    ASSERT_TRUE(score.feasible) << score.reason;
    best = std::min(best, score.validation_mean_m);
  }
  EXPECT_DOUBLE_EQ(fit.cross_validation[static_cast<size_t>(k - 1)].validation_mean_m, best);
  EXPECT_GT(k, 1);  // the field is curved: one expert is not the best
}

TEST(Mixture, CrossValidationNeedsTwoPaths) {
  SyntheticEyeHandParams one;
  one.paths = 1;
  MixtureParams params;
  params.experts = 0;
  EXPECT_THROW(FitMixture(MakeEyeHandSamples(one), params), CalibrationError);
}

TEST(Mixture, TooManyExpertsForTheDataIsRefusedWithAReason) {
  SyntheticEyeHandParams small;
  small.paths = 1;
  small.points_per_path = 60;
  MixtureParams params;
  params.experts = 8;  // 60 samples cannot give 8 experts 12 samples each
  try {
    FitMixture(MakeEyeHandSamples(small), params);
    FAIL() << "K = 8 on 60 samples accepted";
  } catch (const CalibrationError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kDegenerate);
    EXPECT_NE(std::string(e.what()).find("fewer experts"), std::string::npos) << e.what();
  }
  // Enough samples overall but one cluster would be too small: a far-away handful.
  auto samples = MakeEyeHandSamples(small);
  for (int i = 0; i < 5; ++i) {
    EyeHandSample far;
    far.xa = far.xb = Eigen::Vector3d(3.0 + 0.01 * i, 0.01 * (i % 2), 0);
    samples.push_back(far);
  }
  params.experts = 2;
  EXPECT_THROW(FitMixture(samples, params), CalibrationError);
}

TEST(Mixture, ProgressCoversTheWholeFitAndCancels) {
  const Split s = SplitPaths(MakeEyeHandSamples({}), 10);
  MixtureParams params;
  double last = -1;
  bool monotone = true;
  FitMixture(s.train, params, [&](const Progress& p) {
    monotone = monotone && p.fraction >= last - 1e-12;
    last = p.fraction;
    return true;
  });
  EXPECT_TRUE(monotone);
  EXPECT_NEAR(last, 1.0, 1e-12);
  try {
    FitMixture(s.train, params, [&](const Progress& p) { return p.fraction < 0.5; });
    FAIL() << "not cancelled";
  } catch (const CalibrationError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled);
  }
}

TEST(EyeHandCalibration, ReportsErrorsAndRejectsNan) {
  auto all = MakeEyeHandSamples({});
  const Split s = SplitPaths(all, 15);
  const auto r = CalibrateEyeHand(s.train, s.test);
  EXPECT_EQ(r.errors.train.count, s.train.size());
  EXPECT_EQ(r.errors.test.count, s.test.size());
  EXPECT_EQ(r.errors.train_inliers.count, s.train.size() - r.errors.outliers_rejected);
  EXPECT_LT(r.errors.train_inliers.rmse_m, r.errors.train.rmse_m + 1e-12);
  auto bad = s.train;
  bad[3].xb.y() = std::nan("");
  try {
    CalibrateEyeHand(bad, s.test);
    FAIL();
  } catch (const CalibrationError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidInput);
    EXPECT_NE(std::string(e.what()).find("sample 3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace epmap::calibration
