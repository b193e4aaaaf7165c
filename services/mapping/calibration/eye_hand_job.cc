#include "services/mapping/calibration/eye_hand_job.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace epmap::mapping {

namespace {

using calibration::CalibrationError;
using calibration::ErrorCode;

constexpr double kDefaultHoldoutShare = 0.25;
constexpr uint32_t kDefaultFolds = 5;
constexpr uint32_t kMaxExperts = 64;

calibration::EyeHandMethod Method(v1::EyeHandMethod m) {
  switch (m) {
    case v1::SE3:
      return calibration::EyeHandMethod::kSe3;
    case v1::SE3_SCALE:
      return calibration::EyeHandMethod::kSe3Scale;
    default:
      return calibration::EyeHandMethod::kMixture;
  }
}

std::string Join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

}  // namespace

v1::EyeHandSpec WithDefaults(v1::EyeHandSpec spec) {
  if (spec.set().empty()) spec.set_set(kDefaultSampleSet);
  if (spec.holdout_share() == 0 && !spec.no_holdout() && spec.holdout_paths().empty()) {
    spec.set_holdout_share(kDefaultHoldoutShare);
  }
  if (spec.method() == v1::MIXTURE && spec.experts() == 0 && spec.folds() == 0) {
    spec.set_folds(kDefaultFolds);
  }
  if (spec.seed() == 0) spec.set_seed(1);
  return spec;
}

std::string CheckEyeHandSpec(const v1::EyeHandSpec& spec) {
  if (spec.method() != v1::SE3 && spec.method() != v1::SE3_SCALE && spec.method() != v1::MIXTURE) {
    return "eye_hand.method must be SE3, SE3_SCALE or MIXTURE";
  }
  if (spec.method() != v1::MIXTURE && spec.experts() > 1) {
    return "eye_hand.experts applies to MIXTURE only (got " + std::to_string(spec.experts()) +
           " with a single-transform method)";
  }
  if (spec.experts() > kMaxExperts) {
    return "eye_hand.experts must be at most " + std::to_string(kMaxExperts);
  }
  if (!(spec.holdout_share() >= 0 && spec.holdout_share() < 1)) {
    return "eye_hand.holdout_share must be in [0, 1), got " + std::to_string(spec.holdout_share());
  }
  if (spec.no_holdout() && (spec.holdout_share() > 0 || !spec.holdout_paths().empty())) {
    return "eye_hand.no_holdout contradicts holdout_share / holdout_paths";
  }
  if (spec.folds() == 1 || spec.folds() > 100) return "eye_hand.folds must be 2..100 (0 = 5)";
  std::set<std::string> holdout(spec.holdout_paths().begin(), spec.holdout_paths().end());
  for (const auto& p : spec.train_paths()) {
    if (holdout.count(p)) return "path '" + p + "' is both a training and a hold-out path";
  }
  return "";
}

EyeHandJobResult RunEyeHandJob(const v1::EyeHandSpec& spec_in,
                               const std::vector<calibration::EyeHandSample>& samples,
                               const calibration::ProgressCallback& progress) {
  const v1::EyeHandSpec spec = WithDefaults(spec_in);
  if (samples.empty()) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           "sample set '" + spec.set() +
                               "' holds no samples: add some first (AddSamples, `epmapctl calib "
                               "add-samples FILE.csv --set " +
                               spec.set() + "`)");
  }
  calibration::ValidateSamples(samples);
  const auto paths = calibration::PathNames(samples);
  const std::set<std::string> known(paths.begin(), paths.end());
  const auto require_known = [&](const google::protobuf::RepeatedPtrField<std::string>& names,
                                 const char* what) {
    std::vector<std::string> out;
    for (const auto& p : names) {
      if (!known.count(p)) {
        throw CalibrationError(ErrorCode::kInvalidInput, std::string(what) + " path '" + p +
                                                             "' is not in set '" + spec.set() +
                                                             "' (its paths: " + Join(paths) + ")");
      }
      out.push_back(p);
    }
    return out;
  };
  const auto holdout_paths = require_known(spec.holdout_paths(), "hold-out");
  const auto train_paths = require_known(spec.train_paths(), "training");

  std::vector<calibration::EyeHandSample> train, test;
  std::string split;
  if (!holdout_paths.empty()) {
    test = calibration::SelectPaths(samples, holdout_paths, true);
    train = train_paths.empty() ? calibration::SelectPaths(samples, holdout_paths, false)
                                : calibration::SelectPaths(samples, train_paths, true);
    split = "hold-out paths " + Join(holdout_paths);
  } else if (spec.no_holdout() || paths.size() < 2) {
    train = train_paths.empty() ? samples : calibration::SelectPaths(samples, train_paths, true);
    split = paths.size() < 2 && !spec.no_holdout()
                ? "no hold-out (the set has a single path; label samples by path to get one)"
                : "no hold-out";
  } else if (!train_paths.empty()) {
    train = calibration::SelectPaths(samples, train_paths, true);
    test = calibration::SelectPaths(samples, train_paths, false);
    split = "training paths " + Join(train_paths) + ", the others held out";
  } else {
    auto s = calibration::SplitByPaths(samples, spec.holdout_share(), spec.seed());
    train = std::move(s.train);
    test = std::move(s.test);
    split = "hold-out paths " + Join(s.test_paths);
  }
  if (train.empty()) {
    throw CalibrationError(
        ErrorCode::kInvalidInput,
        "no training samples left after the hold-out split of set '" + spec.set() + "'");
  }

  calibration::EyeHandCalibrationParams params;
  params.method = Method(spec.method());
  params.se3.outliers.enabled = !spec.keep_outliers();
  params.mixture.experts = static_cast<int>(spec.experts());
  if (spec.folds() > 0) params.mixture.folds = static_cast<int>(spec.folds());
  params.mixture.seed = spec.seed();
  params.mixture.expert_fit.outliers.enabled = !spec.keep_outliers();

  EyeHandJobResult r;
  r.fit = calibration::CalibrateEyeHand(train, test, params, progress);
  const auto& e = r.fit.errors;
  auto& out = r.errors;
  out.set_initial_mean_m(e.initial.mean_m);
  out.set_initial_rmse_m(e.initial.rmse_m);
  out.set_train_mean_m(e.train.mean_m);
  out.set_train_rmse_m(e.train.rmse_m);
  out.set_holdout_mean_m(e.test.mean_m);
  out.set_holdout_rmse_m(e.test.rmse_m);
  out.set_holdout_median_m(e.test.median_m);
  out.set_holdout_max_m(e.test.max_m);
  out.set_train_count(static_cast<uint32_t>(e.train.count));
  out.set_holdout_count(static_cast<uint32_t>(e.test.count));
  out.set_outliers_rejected(static_cast<uint32_t>(e.outliers_rejected));
  out.set_experts(static_cast<uint32_t>(e.experts));

  std::string method = calibration::ToString(params.method);
  if (params.method == calibration::EyeHandMethod::kMixture) {
    method += " of " + std::to_string(e.experts) + " SE(3) experts";
    if (spec.experts() == 0) {
      method += " (K by " + std::to_string(params.mixture.folds) + "-fold cross-validation)";
    }
  }
  r.description = method + "; set '" + spec.set() + "', " + std::to_string(train.size()) +
                  " training samples, " + std::to_string(test.size()) + " held out (" + split +
                  "); outliers " + (spec.keep_outliers() ? "kept" : "rejected");
  return r;
}

}  // namespace epmap::mapping
