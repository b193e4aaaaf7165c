// epmap-bench calib [--samples FILE.csv] [--vergence DIR] [--fixed-rig DIR]: the algorithms of
// paper 001 on an eye-hand sample set (Eq. 9, Eq. 10) and on a verging stereo sequence
// (Sec. III-A). Prints one JSON object per case; every figure has its baseline beside it
// (uncalibrated error, Eigen::umeyama, the kinematic prior).

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench/epmap_bench/command_registry.h"
#include "bench/epmap_bench/summary.h"
#include "common/dataset/dataset.h"
#include "perception/calibration/dataset_intrinsics.h"
#include "perception/calibration/eye_hand_calibration.h"
#include "perception/calibration/stereo_self_calibration.h"
#include "perception/kinematics/urdf_chain.h"

namespace {

using namespace epmap::calibration;
using Clock = std::chrono::steady_clock;
using namespace epmap::bench;

// ---------------------------------------------------------------------------------------------
// Eye-hand

struct Fitted {
  std::string name;
  EyeHandCalibrationResult result;
};

std::string ErrorsJson(const EyeHandCalibrationResult& r) {
  return "{\"train_mean_m\":" + JsonNumber(r.errors.train.mean_m, 6) +
         ",\"train_rmse_m\":" + JsonNumber(r.errors.train.rmse_m, 6) +
         ",\"test_mean_m\":" + JsonNumber(r.errors.test.mean_m, 6) +
         ",\"test_rmse_m\":" + JsonNumber(r.errors.test.rmse_m, 6) +
         ",\"test_median_m\":" + JsonNumber(r.errors.test.median_m, 6) +
         ",\"outliers_rejected\":" + std::to_string(r.errors.outliers_rejected) +
         ",\"experts\":" + std::to_string(r.errors.experts) + "}";
}

EyeHandCalibrationParams Method(EyeHandMethod m, int experts = 4) {
  EyeHandCalibrationParams p;
  p.method = m;
  p.mixture.experts = experts;
  return p;
}

void EyeHandSplit(const std::vector<EyeHandSample>& all,
                  const std::vector<std::string>& test_paths) {
  const auto train = SelectPaths(all, test_paths, false);
  const auto test = SelectPaths(all, test_paths, true);
  std::string line = "{\"command\":\"calib\",\"case\":\"eye-hand-split\",\"train_paths\":" +
                     std::to_string(PathNames(train).size()) +
                     ",\"test_paths\":" + std::to_string(test_paths.size()) +
                     ",\"train_samples\":" + std::to_string(train.size()) +
                     ",\"test_samples\":" + std::to_string(test.size());
  line += ",\"initial_mean_error_m\":" + JsonNumber(EvaluateUncalibrated(test).mean_m, 6);
  line += ",\"initial_mean_error_all_m\":" + JsonNumber(EvaluateUncalibrated(all).mean_m, 6);
  for (const auto& [name, params] : std::vector<std::pair<std::string, EyeHandCalibrationParams>>{
           {"se3", Method(EyeHandMethod::kSe3)},
           {"se3_scale", Method(EyeHandMethod::kSe3Scale)},
           {"mixture4", Method(EyeHandMethod::kMixture, 4)},
           {"mixture_cv", Method(EyeHandMethod::kMixture, 0)}}) {
    try {
      const auto t0 = Clock::now();
      const auto r = CalibrateEyeHand(train, test, params);
      std::string errors = ErrorsJson(r);
      errors.insert(errors.size() - 1, ",\"fit_ms\":" + JsonNumber(MsSince(t0), 4));
      line += ",\"" + name + "\":" + errors;
    } catch (const CalibrationError& e) {
      line += ",\"" + name + "\":{\"error\":" + JsonQuote(e.what()) + "}";
    }
  }
  std::printf("%s}\n", line.c_str());
}

// Paper Fig. 7: train on one path, test on all the others; medians over every choice of path.
void EyeHandOnePath(const std::vector<EyeHandSample>& all) {
  const auto paths = PathNames(all);
  std::string line = "{\"command\":\"calib\",\"case\":\"eye-hand-one-path\",\"paths\":" +
                     std::to_string(paths.size());
  for (const auto& [name, params] : std::vector<std::pair<std::string, EyeHandCalibrationParams>>{
           {"se3", Method(EyeHandMethod::kSe3)},
           {"se3_scale", Method(EyeHandMethod::kSe3Scale)},
           {"mixture4", Method(EyeHandMethod::kMixture, 4)}}) {
    std::vector<double> train, test, initial;
    int failed = 0;
    std::string reason;
    for (const auto& p : paths) {
      try {
        const auto r =
            CalibrateEyeHand(SelectPaths(all, {p}, true), SelectPaths(all, {p}, false), params);
        train.push_back(r.errors.train.mean_m);
        test.push_back(r.errors.test.mean_m);
        initial.push_back(r.errors.initial.mean_m);
      } catch (const CalibrationError& e) {
        ++failed;
        reason = e.what();
      }
    }
    line += ",\"" + name + "\":{\"train_mean_m_median\":" + JsonNumber(Median(train), 6) +
            ",\"test_mean_m_median\":" + JsonNumber(Median(test), 6) +
            ",\"test_mean_m_worst\":" + JsonNumber(Max(test), 6) +
            ",\"initial_mean_m_median\":" + JsonNumber(Median(initial), 6) +
            ",\"failed\":" + std::to_string(failed) +
            (failed ? ",\"failure\":" + JsonQuote(reason) : std::string()) + "}";
  }
  std::printf("%s}\n", line.c_str());
}

// Paper Fig. 6: test error against the number of training samples (random draws from the
// training paths, median over `repeats` draws).
void EyeHandLearningCurve(const std::vector<EyeHandSample>& all,
                          const std::vector<std::string>& test_paths, uint64_t seed) {
  const auto train = SelectPaths(all, test_paths, false);
  const auto test = SelectPaths(all, test_paths, true);
  const int repeats = 7;
  std::string line = "{\"command\":\"calib\",\"case\":\"eye-hand-learning-curve\",\"repeats\":" +
                     std::to_string(repeats) + ",\"points\":[";
  bool first = true;
  for (int n : {10, 20, 30, 50, 75, 100, 150, 200, 300, 500}) {
    if (n > static_cast<int>(train.size())) break;
    std::vector<double> se3, mix;
    std::mt19937_64 rng(seed + static_cast<uint64_t>(n));
    for (int r = 0; r < repeats; ++r) {
      std::vector<EyeHandSample> pool = train;
      std::shuffle(pool.begin(), pool.end(), rng);
      pool.resize(static_cast<size_t>(n));
      try {
        se3.push_back(CalibrateEyeHand(pool, test, Method(EyeHandMethod::kSe3)).errors.test.mean_m);
      } catch (const CalibrationError&) {
      }
      try {
        mix.push_back(
            CalibrateEyeHand(pool, test, Method(EyeHandMethod::kMixture, 4)).errors.test.mean_m);
      } catch (const CalibrationError&) {
      }
    }
    line += std::string(first ? "" : ",") + "{\"n\":" + std::to_string(n) +
            ",\"se3_test_mean_m\":" + JsonNumber(Median(se3), 6) +
            ",\"se3_fits\":" + std::to_string(se3.size()) +
            ",\"mixture4_test_mean_m\":" + JsonNumber(Median(mix), 6) +
            ",\"mixture4_fits\":" + std::to_string(mix.size()) + "}";
    first = false;
  }
  std::printf("%s]}\n", line.c_str());
}

// NLopt against the closed form, and the time of one fit on 2000 points beside umeyama's.
void EyeHandSolver(const std::vector<EyeHandSample>& all) {
  std::vector<EyeHandSample> pts = all;
  while (pts.size() < 2000) pts.insert(pts.end(), all.begin(), all.end());
  pts.resize(2000);
  const Eigen::Matrix3Xd a = PointsA(pts), b = PointsB(pts);
  const LinearExpert oracle = UmeyamaSe3(a, b);
  const auto rms = [&](const LinearExpert& t) {
    double s = 0;
    for (Eigen::Index i = 0; i < a.cols(); ++i)
      s += (t.Apply(a.col(i)) - oracle.Apply(a.col(i))).squaredNorm();
    return std::sqrt(s / static_cast<double>(a.cols()));
  };
  Se3FitParams plain;
  plain.outliers.enabled = false;
  Se3FitParams from_identity = plain;
  from_identity.init = Se3FitParams::Init::kIdentity;
  const auto fit_id = FitSe3(a, b, from_identity);
  const auto fit_um = FitSe3(a, b, plain);

  const int runs = 41;
  std::vector<double> t_default, t_plain, t_identity, t_umeyama;
  const Se3FitParams defaults;
  for (int r = 0; r < runs; ++r) {
    auto t0 = Clock::now();
    const auto f1 = FitSe3(a, b, defaults);
    t_default.push_back(MsSince(t0));
    t0 = Clock::now();
    const auto f2 = FitSe3(a, b, plain);
    t_plain.push_back(MsSince(t0));
    t0 = Clock::now();
    const auto f3 = FitSe3(a, b, from_identity);
    t_identity.push_back(MsSince(t0));
    t0 = Clock::now();
    const Eigen::Matrix4d h = Eigen::umeyama(a, b, false);
    t_umeyama.push_back(MsSince(t0));
    if (!h.allFinite() || f1.stats.samples + f2.stats.samples + f3.stats.samples == 0) return;
  }
  std::printf(
      "{\"command\":\"calib\",\"case\":\"eye-hand-solver\",\"points\":%zu,"
      "\"nlopt_vs_umeyama_rms_m\":{\"from_identity\":%s,\"from_umeyama\":%s},"
      "\"nlopt_evaluations\":{\"from_identity\":%d,\"from_umeyama\":%d},"
      "\"fit_ms_median\":{\"se3_default\":%s,\"se3_no_outlier_rule\":%s,"
      "\"se3_from_identity_no_outlier_rule\":%s,\"umeyama_baseline\":%s},"
      "\"ratio_default_to_umeyama\":%s,\"runs\":%d}\n",
      pts.size(), JsonNumber(rms(fit_id.transform), 3).c_str(),
      JsonNumber(rms(fit_um.transform), 3).c_str(), fit_id.stats.evaluations,
      fit_um.stats.evaluations, JsonNumber(Median(t_default), 4).c_str(),
      JsonNumber(Median(t_plain), 4).c_str(), JsonNumber(Median(t_identity), 4).c_str(),
      JsonNumber(Median(t_umeyama), 4).c_str(),
      JsonNumber(Median(t_default) / Median(t_umeyama), 4).c_str(), runs);
}

int RunEyeHand(const std::string& csv, uint64_t seed, int test_path_count) {
  const auto all = ReadEyeHandCsv(csv);
  const auto paths = PathNames(all);
  const PathSplit split = SplitByPaths(
      all, static_cast<double>(test_path_count) / static_cast<double>(paths.size()), seed);
  EyeHandSplit(all, split.test_paths);
  EyeHandOnePath(all);
  EyeHandLearningCurve(all, split.test_paths, seed);
  EyeHandSolver(all);
  return 0;
}

// ---------------------------------------------------------------------------------------------
// Vergence

struct GtExtrinsics {
  int64_t stamp_ns;
  Eigen::Isometry3d T_cam0_cam1;
};

std::vector<GtExtrinsics> ReadGtExtrinsics(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error("cannot open " + csv.string());
  std::vector<GtExtrinsics> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string f;
    std::vector<double> v;
    int64_t stamp = 0;
    for (int i = 0; std::getline(ss, f, ','); ++i) {
      if (i == 0) {
        stamp = std::stoll(f);
      } else {
        v.push_back(std::stod(f));
      }
    }
    if (v.size() != 7) throw std::runtime_error(csv.string() + ": expected 8 columns: " + line);
    GtExtrinsics g{stamp, Eigen::Isometry3d::Identity()};
    g.T_cam0_cam1.linear() =
        Eigen::Quaterniond(v[3], v[4], v[5], v[6]).normalized().toRotationMatrix();
    g.T_cam0_cam1.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    out.push_back(g);
  }
  return out;
}

// Kinematic mode (fixed_rig_error_deg < 0): prior from joints0 through kinematics.urdf, truth
// from gt_extrinsics0. Fixed-rig mode (a calibrated rig such as EuRoC): truth from the two
// sensor.yaml T_BS, prior = truth with its rotation off by fixed_rig_error_deg.
int RunVergence(const std::string& dir, int max_frames, int group, double direction_prior_deg,
                bool verbose, double fixed_rig_error_deg) {
  const auto d = epmap::dataset::Load(dir);
  const bool fixed_rig = fixed_rig_error_deg >= 0;
  std::map<int64_t, Eigen::Isometry3d> truth;
  std::optional<epmap::kinematics::UrdfChain> chain;
  const Eigen::Isometry3d rig_truth(d.cam0.T_BS.inverse() * d.cam1.T_BS);
  if (fixed_rig) {
    for (const auto& f : d.frames) truth[f.stamp_ns] = rig_truth;
  } else {
    if (!d.urdf) throw std::runtime_error(dir + ": no mav0/kinematics.urdf for the prior");
    if (d.joints.empty()) throw std::runtime_error(dir + ": no joints0 readings for the prior");
    chain.emplace(epmap::kinematics::UrdfChain::FromFile(*d.urdf));
    chain->BindJointOrder(d.joint_names);
    for (const auto& g : ReadGtExtrinsics(d.root / "mav0" / "gt_extrinsics0" / "data.csv")) {
      truth[g.stamp_ns] = g.T_cam0_cam1;
    }
  }
  const CameraIntrinsics c0 = IntrinsicsOf(d.cam0), c1 = IntrinsicsOf(d.cam1);
  const StereoSelfCalibrationParams params;  // the paper's procedure: data only
  StereoSelfCalibrationParams with_prior;    // plus the optional baseline-direction prior
  with_prior.baseline_direction_prior_sigma_deg = direction_prior_deg;
  std::vector<double> wp_rot, wp_dir;
  std::map<std::string, int> wp_failures;
  std::vector<double> group_spread;

  const int n = static_cast<int>(d.frames.size());
  const int step = std::max(1, n / std::max(1, max_frames));
  std::vector<double> rot, dir_err, prior_rot, prior_dir, vo_rec, vo_prior, vo_true, ms;
  std::map<std::string, int> failures;
  int tried = 0;
  std::vector<double> multi_rot, multi_dir;
  int multi_tried = 0;
  std::map<std::string, int> multi_failures;
  const auto prior_at = [&](int64_t stamp) {
    if (fixed_rig) {
      Eigen::Isometry3d p = rig_truth;
      p.rotate(Eigen::AngleAxisd(fixed_rig_error_deg * M_PI / 180,
                                 Eigen::Vector3d(0.3, 1.0, 0.2).normalized()));
      return p;
    }
    const auto j = epmap::dataset::InterpolateJoints(d.joints, stamp);
    if (!j) throw std::runtime_error("no joint reading near frame " + std::to_string(stamp));
    return KinematicPrior(*chain, *j);
  };
  for (int i = 0; i < n && tried < max_frames; i += step) {
    const auto& f = d.frames[static_cast<size_t>(i)];
    const auto it = truth.find(f.stamp_ns);
    if (it == truth.end()) continue;
    ++tried;
    StereoView v;
    v.left = cv::imread(f.left.string(), cv::IMREAD_UNCHANGED);
    v.right = cv::imread(f.right.string(), cv::IMREAD_UNCHANGED);
    v.T_cam0_cam1_prior = prior_at(f.stamp_ns);
    v.stamp_ns = f.stamp_ns;
    const Eigen::Isometry3d& t = it->second;
    prior_rot.push_back(RotationAngleDeg(v.T_cam0_cam1_prior.linear(), t.linear()));
    prior_dir.push_back(DirectionAngleDeg(v.T_cam0_cam1_prior.translation(), t.translation()));
    try {
      const auto t0 = Clock::now();
      const auto r = SelfCalibrateStereo(c0, c1, {v}, params);
      ms.push_back(MsSince(t0));
      rot.push_back(RotationAngleDeg(r.model.T_cam0_cam1.linear(), t.linear()));
      dir_err.push_back(DirectionAngleDeg(r.model.T_cam0_cam1.translation(), t.translation()));
      vo_rec.push_back(MedianRowOffset(c0, c1, r.model.T_cam0_cam1, v.left, v.right));
      vo_prior.push_back(MedianRowOffset(c0, c1, v.T_cam0_cam1_prior, v.left, v.right));
      vo_true.push_back(MedianRowOffset(c0, c1, t, v.left, v.right));
      if (verbose) {
        std::fprintf(stderr,
                     "frame %d: keypoints %d/%d putative %d gated %d inliers %d homography %d "
                     "rms %.3f px, rotation error %.3f deg, direction error %.3f deg\n",
                     i, r.keypoints_left, r.keypoints_right, r.putative_matches,
                     r.prior_consistent_matches, r.model.inliers, r.homography_inliers,
                     r.model.rms_sampson_px, rot.back(), dir_err.back());
      }
    } catch (const CalibrationError& e) {
      ++failures[ToString(e.code())];
      if (verbose) std::fprintf(stderr, "frame %d: %s\n", i, e.what());
    }
    if (direction_prior_deg > 0) {
      try {
        const auto r = SelfCalibrateStereo(c0, c1, {v}, with_prior);
        wp_rot.push_back(RotationAngleDeg(r.model.T_cam0_cam1.linear(), t.linear()));
        wp_dir.push_back(DirectionAngleDeg(r.model.T_cam0_cam1.translation(), t.translation()));
      } catch (const CalibrationError& e) {
        ++wp_failures[ToString(e.code())];
      }
    }
    // Multi-frame: this frame and the next group-1 ones, when they share one eye configuration.
    if (group > 1 && i + group <= n) {
      std::vector<StereoView> views{v};
      for (int k = 1; k < group; ++k) {
        const auto& g = d.frames[static_cast<size_t>(i + k)];
        StereoView w;
        w.left = cv::imread(g.left.string(), cv::IMREAD_UNCHANGED);
        w.right = cv::imread(g.right.string(), cv::IMREAD_UNCHANGED);
        w.T_cam0_cam1_prior = prior_at(g.stamp_ns);
        group_spread.push_back(
            std::max(RotationAngleDeg(v.T_cam0_cam1_prior.linear(), w.T_cam0_cam1_prior.linear()),
                     DirectionAngleDeg(v.T_cam0_cam1_prior.translation(),
                                       w.T_cam0_cam1_prior.translation())));
        views.push_back(w);
      }
      ++multi_tried;
      try {
        const auto r = SelfCalibrateStereo(c0, c1, views, params);
        multi_rot.push_back(RotationAngleDeg(r.model.T_cam0_cam1.linear(), t.linear()));
        multi_dir.push_back(DirectionAngleDeg(r.model.T_cam0_cam1.translation(), t.translation()));
      } catch (const CalibrationError& e) {
        ++multi_failures[ToString(e.code())];
        if (verbose) std::fprintf(stderr, "frames %d..%d: %s\n", i, i + group - 1, e.what());
      }
    }
  }
  const auto failures_json = [](const std::map<std::string, int>& m) {
    std::string s = "{";
    for (const auto& [k, v] : m)
      s += (s.size() > 1 ? "," : "") + JsonQuote(k) + ":" + std::to_string(v);
    return s + "}";
  };
  std::printf(
      "{\"command\":\"calib\",\"case\":\"%s\",\"frames\":%d,\"evaluated\":%d,"
      "\"succeeded\":%zu,\"failures\":%s,"
      "\"rotation_error_deg\":%s,\"baseline_direction_error_deg\":%s,"
      "\"prior_rotation_error_deg\":%s,\"prior_baseline_direction_error_deg\":%s,"
      "\"vertical_offset_px\":{\"recovered\":%s,\"kinematic_prior\":%s,\"ground_truth\":%s},"
      "\"self_calibration_ms_median\":%s,"
      "\"with_direction_prior\":{\"sigma_deg\":%s,\"failures\":%s,\"rotation_error_deg\":%s,"
      "\"baseline_direction_error_deg\":%s},"
      "\"multi_frame\":{\"frames_per_call\":%d,\"calls\":%d,\"failures\":%s,"
      "\"prior_spread_within_group_deg\":%s,"
      "\"rotation_error_deg\":%s,\"baseline_direction_error_deg\":%s}}\n",
      fixed_rig ? "fixed-rig" : "vergence", n, tried, rot.size(), failures_json(failures).c_str(),
      JsonMedianMax(rot).c_str(), JsonMedianMax(dir_err).c_str(), JsonMedianMax(prior_rot).c_str(),
      JsonMedianMax(prior_dir).c_str(), JsonMedianMax(vo_rec).c_str(),
      JsonMedianMax(vo_prior).c_str(), JsonMedianMax(vo_true).c_str(),
      JsonNumber(Median(ms), 4).c_str(), JsonNumber(direction_prior_deg, 6).c_str(),
      failures_json(wp_failures).c_str(), JsonMedianMax(wp_rot).c_str(),
      JsonMedianMax(wp_dir).c_str(), group, multi_tried, failures_json(multi_failures).c_str(),
      JsonMedianMax(group_spread).c_str(), JsonMedianMax(multi_rot).c_str(),
      JsonMedianMax(multi_dir).c_str());
  return 0;
}

int Run(int argc, char** argv) {
  CLI::App app("paper 001 calibration: eye-hand fits and stereo self-calibration", argv[0]);
  std::string samples, vergence, fixed_rig;
  double prior_error_deg = 1.0;
  uint64_t seed = 1;
  int test_paths = 5, max_frames = 30, group = 3;
  double direction_prior_deg = 0.5;
  bool verbose = false;
  app.add_option("--samples", samples, "eye-hand samples CSV (epmap-sim --scenario eye-hand)");
  app.add_option("--vergence", vergence, "vergence dataset folder (epmap-sim --scenario vergence)");
  app.add_option("--fixed-rig", fixed_rig,
                 "calibrated fixed stereo sequence (e.g. EuRoC): truth = the T_BS of sensor.yaml");
  app.add_option("--prior-error-deg", prior_error_deg,
                 "--fixed-rig: rotation error given to the prior (default 1)");
  app.add_option("--seed", seed, "seed of the train/test path split and the learning curve");
  app.add_option("--test-paths", test_paths, "paths held out for testing (default 5)");
  app.add_option("--frames", max_frames, "vergence frames evaluated, evenly spread (default 30)");
  app.add_option("--group", group, "frames per multi-frame self-calibration (default 3; 1 = skip)");
  app.add_option("--direction-prior-deg", direction_prior_deg,
                 "also run with a baseline-direction prior of this sigma (default 0.5; 0 = skip)");
  app.add_flag("--verbose", verbose, "per-frame diagnostics on stderr");
  CLI11_PARSE(app, argc, argv);
  if (samples.empty() && vergence.empty() && fixed_rig.empty()) {
    std::cerr << "epmap-bench calib: give --samples FILE.csv, --vergence DIR or --fixed-rig DIR\n";
    return 2;
  }
  try {
    if (!samples.empty()) RunEyeHand(samples, seed, test_paths);
    if (!vergence.empty()) {
      RunVergence(vergence, max_frames, group, direction_prior_deg, verbose, -1.0);
    }
    if (!fixed_rig.empty()) {
      RunVergence(fixed_rig, max_frames, group, direction_prior_deg, verbose,
                  std::max(0.0, prior_error_deg));
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "epmap-bench calib: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

EPMAP_BENCH_COMMAND(calib, "calib", "eye-hand SE(3)/mixture fits and stereo self-calibration", Run);
