#include "perception/calibration/mixture.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace epmap::calibration {

namespace {

// Uniform in [0, 1) from the generator's bits: identical on every standard library.
double Uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

KMeansResult KMeansOnce(const Eigen::Matrix3Xd& p, int k, std::mt19937_64& rng,
                        int max_iterations) {
  const Eigen::Index n = p.cols();
  KMeansResult r;
  r.centres.resize(3, k);
  // k-means++: first centre uniform, each next one drawn with probability ~ D(x)^2.
  r.centres.col(0) = p.col(static_cast<Eigen::Index>(Uniform01(rng) * static_cast<double>(n)));
  Eigen::VectorXd d2 = (p.colwise() - r.centres.col(0)).colwise().squaredNorm().transpose();
  for (int c = 1; c < k; ++c) {
    const double total = d2.sum();
    Eigen::Index pick = n - 1;
    if (total > 0) {
      double u = Uniform01(rng) * total;
      for (Eigen::Index i = 0; i < n; ++i) {
        u -= d2(i);
        if (u < 0) {
          pick = i;
          break;
        }
      }
    } else {
      pick = static_cast<Eigen::Index>(Uniform01(rng) * static_cast<double>(n));
    }
    r.centres.col(c) = p.col(pick);
    d2 = d2.cwiseMin((p.colwise() - r.centres.col(c)).colwise().squaredNorm().transpose());
  }
  r.assignment.assign(static_cast<size_t>(n), -1);
  for (int it = 0; it < max_iterations; ++it) {
    bool changed = false;
    r.inertia = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      Eigen::Index best = 0;
      const double dist = (r.centres.colwise() - p.col(i)).colwise().squaredNorm().minCoeff(&best);
      r.inertia += dist;
      if (r.assignment[static_cast<size_t>(i)] != static_cast<int>(best)) {
        r.assignment[static_cast<size_t>(i)] = static_cast<int>(best);
        changed = true;
      }
    }
    if (!changed) break;
    Eigen::Matrix3Xd sum = Eigen::Matrix3Xd::Zero(3, k);
    Eigen::VectorXd count = Eigen::VectorXd::Zero(k);
    for (Eigen::Index i = 0; i < n; ++i) {
      sum.col(r.assignment[static_cast<size_t>(i)]) += p.col(i);
      count(r.assignment[static_cast<size_t>(i)]) += 1;
    }
    for (int c = 0; c < k; ++c) {
      if (count(c) > 0) {
        r.centres.col(c) = sum.col(c) / count(c);
      } else {
        // An emptied cluster takes the point worst served by its centre.
        Eigen::Index worst = 0;
        double worst_d = -1;
        for (Eigen::Index i = 0; i < n; ++i) {
          const double d =
              (p.col(i) - r.centres.col(r.assignment[static_cast<size_t>(i)])).squaredNorm();
          if (d > worst_d) {
            worst_d = d;
            worst = i;
          }
        }
        r.centres.col(c) = p.col(worst);
      }
    }
  }
  return r;
}

std::string ClusterName(int i, int k) {
  return "cluster " + std::to_string(i + 1) + " of " + std::to_string(k);
}

MixtureFitResult FitWithK(const std::vector<EyeHandSample>& samples, int k,
                          const MixtureParams& params, const ProgressCallback& progress) {
  const auto n = static_cast<int>(samples.size());
  if (k < 1) throw CalibrationError(ErrorCode::kInvalidInput, "the mixture needs K >= 1 experts");
  if (n < k * params.min_samples_per_expert) {
    throw CalibrationError(ErrorCode::kDegenerate,
                           std::to_string(k) + " experts need at least " +
                               std::to_string(k * params.min_samples_per_expert) + " samples (" +
                               std::to_string(params.min_samples_per_expert) +
                               " per expert), got " + std::to_string(n) +
                               ": use fewer experts or collect more samples");
  }
  const Eigen::Matrix3Xd xa = PointsA(samples);
  const Eigen::Matrix3Xd xb = PointsB(samples);
  MixtureFitResult result;
  const KMeansResult km =
      KMeans(xa, k, params.seed, params.kmeans_restarts, params.kmeans_max_iterations);
  result.assignment = km.assignment;
  result.inlier.assign(samples.size(), 0);
  std::vector<LinearExpert> experts;
  for (int c = 0; c < k; ++c) {
    std::vector<Eigen::Index> members;
    for (int i = 0; i < n; ++i) {
      if (km.assignment[static_cast<size_t>(i)] == c) members.push_back(i);
    }
    const auto m = static_cast<Eigen::Index>(members.size());
    if (m < params.min_samples_per_expert) {
      throw CalibrationError(ErrorCode::kDegenerate,
                             "K = " + std::to_string(k) +
                                 " is too many experts: " + ClusterName(c, k) + " has " +
                                 std::to_string(m) + " samples (each expert needs at least " +
                                 std::to_string(params.min_samples_per_expert) +
                                 "); use fewer experts or collect more samples");
    }
    Eigen::Matrix3Xd ca(3, m), cb(3, m);
    for (Eigen::Index j = 0; j < m; ++j) {
      ca.col(j) = xa.col(members[static_cast<size_t>(j)]);
      cb.col(j) = xb.col(members[static_cast<size_t>(j)]);
    }
    Se3FitResult fit;
    try {
      fit = FitSe3(
          ca, cb, params.expert_fit,
          ProgressSubrange(progress, static_cast<double>(c) / k, static_cast<double>(c + 1) / k));
    } catch (const CalibrationError& e) {
      if (e.code() != ErrorCode::kDegenerate) throw;
      throw CalibrationError(ErrorCode::kDegenerate, "K = " + std::to_string(k) + ": " +
                                                         ClusterName(c, k) + ": " + e.what() +
                                                         " (use fewer experts)");
    }
    for (Eigen::Index j = 0; j < m; ++j) {
      result.inlier[static_cast<size_t>(members[static_cast<size_t>(j)])] =
          fit.inlier[static_cast<size_t>(j)];
    }
    LinearExpert e = fit.transform;
    e.covariance +=
        params.covariance_floor_m * params.covariance_floor_m * Eigen::Matrix3d::Identity();
    experts.push_back(e);
    result.outliers_rejected += fit.stats.rejected;
    result.expert_stats.push_back(fit.stats);
  }
  result.model = EyeHandModel(EyeHandMethod::kMixture, std::move(experts));
  return result;
}

}  // namespace

KMeansResult KMeans(const Eigen::Matrix3Xd& points, int k, uint64_t seed, int restarts,
                    int max_iterations) {
  if (k < 1 || k > points.cols()) {
    throw CalibrationError(ErrorCode::kInvalidInput, "k-means with k = " + std::to_string(k) +
                                                         " on " + std::to_string(points.cols()) +
                                                         " points");
  }
  std::mt19937_64 rng(seed);
  KMeansResult best;
  best.inertia = std::numeric_limits<double>::infinity();
  for (int r = 0; r < std::max(1, restarts); ++r) {
    KMeansResult candidate = KMeansOnce(points, k, rng, max_iterations);
    if (candidate.inertia < best.inertia) best = std::move(candidate);
  }
  return best;
}

ProgressCallback ProgressSubrange(const ProgressCallback& progress, double begin, double end) {
  if (!progress) return {};
  return [progress, begin, end](const Progress& p) {
    Progress q = p;
    q.fraction = begin + (end - begin) * std::clamp(p.fraction, 0.0, 1.0);
    return progress(q);
  };
}

MixtureFitResult FitMixture(const std::vector<EyeHandSample>& samples, const MixtureParams& params,
                            const ProgressCallback& progress) {
  ValidateSamples(samples);
  if (params.experts > 0) return FitWithK(samples, params.experts, params, progress);
  if (params.experts < 0 || params.max_experts < 1 || params.folds < 2) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           "mixture: experts must be >= 0, max_experts >= 1 and folds >= 2");
  }

  // K by k-fold cross-validation over paths: whole paths are held out, so the score measures
  // generalisation to unseen trajectories (the paper's test protocol), not interpolation.
  std::vector<std::string> paths = PathNames(samples);
  if (paths.size() < 2) {
    throw CalibrationError(ErrorCode::kDegenerate,
                           "choosing K by cross-validation needs samples from at least 2 paths, "
                           "got " +
                               std::to_string(paths.size()) + ": give K explicitly");
  }
  std::sort(paths.begin(), paths.end());
  std::mt19937_64 rng(params.seed);
  for (size_t i = paths.size() - 1; i > 0; --i) {  // Fisher-Yates with our own uniform draws
    const auto j = static_cast<size_t>(Uniform01(rng) * static_cast<double>(i + 1));
    std::swap(paths[i], paths[j]);
  }
  const int folds = std::min<int>(params.folds, static_cast<int>(paths.size()));
  std::vector<std::vector<std::string>> fold_paths(static_cast<size_t>(folds));
  for (size_t i = 0; i < paths.size(); ++i)
    fold_paths[i % static_cast<size_t>(folds)].push_back(paths[i]);

  std::vector<CrossValidationScore> scores;
  const double cv_share = 0.9;  // of the progress bar; the final fit takes the rest
  const int jobs = params.max_experts * folds;
  for (int k = 1; k <= params.max_experts; ++k) {
    CrossValidationScore score;
    score.experts = k;
    score.feasible = true;
    std::vector<double> distances;
    for (int f = 0; f < folds && score.feasible; ++f) {
      const int job = (k - 1) * folds + f;
      const auto& held_out = fold_paths[static_cast<size_t>(f)];
      try {
        const auto fit = FitWithK(
            SelectPaths(samples, held_out, false), k, params,
            ProgressSubrange(progress, cv_share * job / jobs, cv_share * (job + 1) / jobs));
        for (const auto& s : SelectPaths(samples, held_out, true)) {
          distances.push_back((s.xb - fit.model.Apply(s.xa)).norm());
        }
      } catch (const CalibrationError& e) {
        if (e.code() != ErrorCode::kDegenerate) throw;
        score.feasible = false;
        score.reason = e.what();
      }
    }
    if (score.feasible) {
      const ErrorSummary s = Summarise(distances);
      score.validation_mean_m = s.mean_m;
      score.validation_rmse_m = s.rmse_m;
    }
    scores.push_back(score);
  }
  const CrossValidationScore* best = nullptr;
  for (const auto& s : scores) {
    if (s.feasible && (!best || s.validation_mean_m < best->validation_mean_m)) best = &s;
  }
  if (!best) {
    throw CalibrationError(
        ErrorCode::kDegenerate,
        "no K in 1.." + std::to_string(params.max_experts) +
            " can be fitted on every cross-validation fold: " + scores.front().reason);
  }
  MixtureFitResult result =
      FitWithK(samples, best->experts, params, ProgressSubrange(progress, cv_share, 1.0));
  result.cross_validation = std::move(scores);
  return result;
}

}  // namespace epmap::calibration
