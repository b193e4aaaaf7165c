#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <map>
#include <set>

#include "clients/sim/scenario.h"

namespace epmap::sim {
namespace {

// The checks of paper 001, Sec. III-B, done here with plain Eigen so that the scenario is
// known to be fit for the calibration experiments: a rigid fit (Eq. 9) and a mixture of
// local rigid fits blended by Mahalanobis RBF weights (Eq. 10).
using Points = std::vector<Eigen::Vector3d>;

Eigen::Matrix4d FitSe3(const Points& from, const Points& to) {
  Eigen::Matrix3Xd a(3, from.size()), b(3, to.size());
  for (size_t i = 0; i < from.size(); ++i) {
    a.col(static_cast<Eigen::Index>(i)) = from[i];
    b.col(static_cast<Eigen::Index>(i)) = to[i];
  }
  return Eigen::umeyama(a, b, false);
}

Eigen::Vector3d Apply(const Eigen::Matrix4d& H, const Eigen::Vector3d& x) {
  return H.topLeftCorner<3, 3>() * x + H.topRightCorner<3, 1>();
}

struct Expert {
  Eigen::Matrix4d H;
  Eigen::Vector3d centre;
  Eigen::Matrix3d inverse_covariance;
};

// k-means with farthest-point initialisation (deterministic), then one SE(3) fit per cluster.
std::vector<Expert> FitMixture(const Points& xa, const Points& xb, int k) {
  std::vector<Eigen::Vector3d> centres = {xa[0]};
  while (static_cast<int>(centres.size()) < k) {
    size_t best = 0;
    double best_d = -1;
    for (size_t i = 0; i < xa.size(); ++i) {
      double d = 1e9;
      for (const auto& c : centres) d = std::min(d, (xa[i] - c).squaredNorm());
      if (d > best_d) best_d = d, best = i;
    }
    centres.push_back(xa[best]);
  }
  std::vector<int> label(xa.size(), 0);
  for (int iter = 0; iter < 50; ++iter) {
    for (size_t i = 0; i < xa.size(); ++i) {
      double best = 1e9;
      for (int c = 0; c < k; ++c) {
        const double d = (xa[i] - centres[static_cast<size_t>(c)]).squaredNorm();
        if (d < best) best = d, label[i] = c;
      }
    }
    for (int c = 0; c < k; ++c) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      int n = 0;
      for (size_t i = 0; i < xa.size(); ++i) {
        if (label[i] == c) sum += xa[i], ++n;
      }
      if (n) centres[static_cast<size_t>(c)] = sum / n;
    }
  }
  std::vector<Expert> experts;
  for (int c = 0; c < k; ++c) {
    Points a, b;
    for (size_t i = 0; i < xa.size(); ++i) {
      if (label[i] == c) a.push_back(xa[i]), b.push_back(xb[i]);
    }
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& p : a)
      cov +=
          (p - centres[static_cast<size_t>(c)]) * (p - centres[static_cast<size_t>(c)]).transpose();
    cov /= static_cast<double>(a.size());
    experts.push_back({FitSe3(a, b), centres[static_cast<size_t>(c)], cov.inverse()});
  }
  return experts;
}

// Eq. 10: w_i ~ exp(-(c_i - x)^T S_i^-1 (c_i - x)), normalised; X = sum w_i H_i x.
Eigen::Vector3d ApplyMixture(const std::vector<Expert>& experts, const Eigen::Vector3d& x) {
  std::vector<double> logw;
  for (const auto& e : experts)
    logw.push_back(-(e.centre - x).dot(e.inverse_covariance * (e.centre - x)));
  const double top = *std::max_element(logw.begin(), logw.end());
  double sum = 0;
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < experts.size(); ++i) {
    const double w = std::exp(logw[i] - top);
    sum += w;
    out += w * Apply(experts[i].H, x);
  }
  return out / sum;
}

struct Split {
  Points train_a, train_b, test_a, test_b;
};

Split SplitByPath(const std::vector<EyeHandSample>& samples, int train_paths) {
  Split s;
  for (const auto& x : samples) {
    const bool train = std::stoi(x.path.substr(1)) < train_paths;
    (train ? s.train_a : s.test_a).push_back(x.xa);
    (train ? s.train_b : s.test_b).push_back(x.xb);
  }
  return s;
}

TEST(EyeHandScenario, TwentyEllipsoidalPathsOfOneHundredSamples) {
  ScenarioOptions o;
  o.name = "eye-hand";
  const auto s = MakeScenario(o);
  EXPECT_EQ(s->frame_count(), 0);
  EXPECT_THROW(s->Render(0), std::logic_error);
  const auto samples = s->EyeHandSamples();
  ASSERT_EQ(samples.size(), 2000u);
  std::map<std::string, int> per_path;
  for (const auto& x : samples) per_path[x.path]++;
  EXPECT_EQ(per_path.size(), 20u);
  EXPECT_EQ(per_path.begin()->first, "e00");
  EXPECT_EQ(per_path.rbegin()->first, "e19");
  for (const auto& [path, n] : per_path) EXPECT_EQ(n, 100) << path;
  for (size_t i = 1; i < samples.size(); ++i)
    EXPECT_GT(samples[i].stamp_ns, samples[i - 1].stamp_ns);
}

TEST(EyeHandScenario, ErrorIsAboutFourCentimetresAndOnlyPartlyRigid) {
  double mean_initial = 0, mean_single = 0;
  for (uint64_t seed : {1u, 2u, 3u, 4u, 5u, 6u}) {
    ScenarioOptions o;
    o.name = "eye-hand";
    o.seed = seed;
    const auto samples = MakeScenario(o)->EyeHandSamples();
    double initial = 0;
    for (const auto& x : samples) initial += (x.xa - x.xb).norm();
    initial /= samples.size();

    const Split split = SplitByPath(samples, 16);  // train on 16 paths, test on 4 new ones
    const Eigen::Matrix4d H = FitSe3(split.train_a, split.train_b);
    const auto experts = FitMixture(split.train_a, split.train_b, 4);
    double single = 0, mixture = 0;
    for (size_t i = 0; i < split.test_a.size(); ++i) {
      single += (Apply(H, split.test_a[i]) - split.test_b[i]).norm();
      mixture += (ApplyMixture(experts, split.test_a[i]) - split.test_b[i]).norm();
    }
    single /= split.test_a.size();
    mixture /= split.test_a.size();
    std::printf("seed %d: initial %.2f cm, single SE(3) test %.2f cm, 4-expert mixture %.2f cm\n",
                static_cast<int>(seed), 100 * initial, 100 * single, 100 * mixture);
    EXPECT_GT(initial, 0.033);
    EXPECT_LT(initial, 0.047);
    EXPECT_GT(single, 0.010);
    EXPECT_LT(single, 0.022);
    EXPECT_LT(mixture, 0.008);
    EXPECT_LT(mixture, 0.6 * single);
    mean_initial += initial / 6;
    mean_single += single / 6;
  }
  // On average: the paper's 4 cm before calibration, 1.2-2 cm left by one rigid fit.
  EXPECT_NEAR(mean_initial, 0.04, 0.004);
  EXPECT_GT(mean_single, 0.012);
  EXPECT_LT(mean_single, 0.020);
}

TEST(EyeHandScenario, NoNoiseLeavesOnlyTheSmoothError) {
  ScenarioOptions o;
  o.name = "eye-hand";
  o.noise = false;
  const auto a = MakeScenario(o)->EyeHandSamples();
  o.noise = true;
  const auto b = MakeScenario(o)->EyeHandSamples();
  ASSERT_EQ(a.size(), b.size());
  double noise = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].xb, b[i].xb);
    noise += (a[i].xa - b[i].xa).norm();
  }
  EXPECT_NEAR(noise / a.size(), 0.0015 * std::sqrt(8 / 3.14159265), 0.0004);  // E|n|, 1.5 mm/axis
}

}  // namespace
}  // namespace epmap::sim
