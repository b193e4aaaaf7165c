// epmap-bench ep --dataset DIR [--out DIR] [--json] [--num-disparities N] [--frames N]
//                [--internal-model urdf|learned] [--set KEY=VALUE ...] [--settle-frames N]
//
// The expected-perception map (perception/ep) against its baseline, full-frame SGBM with the
// same parameters, on the same frames in the same run (interleaved frame by frame, alternating
// which goes first). Reports speed (per-frame compute, medians and the median per-frame ratio),
// the recomputed share, bad-2 of both against the true disparity when the dataset has it
// (unknown pixels count as wrong; also over the first and the last 50 frames: no drift), the
// unexpected mask against the true mask (IoU on frames where the moving thing is visible, the
// flagged area on frames where it is not), and the paper's Fig. 6k means of E and A (overall
// and after C has settled).
//
// Any dataset in the layout of ../shared/docs/dataset-layout.md: camera poses from
// mav0/kinematics.urdf + joints0 (joint names must match), or a fixed rig without them, on a
// mobile base's odometry0 when the dataset has one (JSON "base_odometry");
// unrectified pairs are rectified first (StereoRectifyFromExtrinsics + Rectifier), as the
// service does. --internal-model learned also trains the paper's learned internal model (Sec.
// III) on the URDF chain over the recorded neck range and runs the EP a second time with it.
// With --out, every frame's EP disparity (<timestamp>.pfm, float32 px, NaN = unknown) and
// unexpected mask (<timestamp>.png, 255 = unexpected) are written there.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "bench/epmap_bench/command_registry.h"
#include "bench/epmap_bench/summary.h"
#include "common/dataset/dataset.h"
#include "common/imaging/pfm.h"
#include "perception/ep/ep_settings.h"
#include "perception/ep/expected_perception.h"
#include "perception/ep/update/roi_stereo.h"
#include "perception/internal_model/learned_pose_model.h"
#include "perception/internal_model/pose_source.h"
#include "perception/kinematics/urdf_chain.h"
#include "perception/stereo/metrics.h"
#include "perception/stereo/rectification.h"
#include "perception/stereo/sgbm.h"

namespace {

namespace fs = std::filesystem;
using epmap::dataset::Dataset;
using Clock = std::chrono::steady_clock;
using namespace epmap::bench;

// ---- a small JSON object writer (NaN becomes null) ----
class Json {
 public:
  Json& Num(const std::string& key, double v) {
    std::ostringstream s;
    if (std::isfinite(v)) {
      s.precision(6);
      s << v;
    } else {
      s << "null";
    }
    return Raw(key, s.str());
  }
  Json& Int(const std::string& key, long long v) { return Raw(key, std::to_string(v)); }
  Json& Str(const std::string& key, const std::string& v) { return Raw(key, JsonQuote(v)); }
  Json& Bool(const std::string& key, bool v) { return Raw(key, v ? "true" : "false"); }
  Json& Raw(const std::string& key, const std::string& v) {
    parts_.push_back("\"" + key + "\":" + v);
    return *this;
  }
  std::string str() const {
    std::string out = "{";
    for (size_t i = 0; i < parts_.size(); ++i) out += (i ? "," : "") + parts_[i];
    return out + "}";
  }

 private:
  std::vector<std::string> parts_;
};

// CPU time of the whole process (all threads), ms: what a computation costs regardless of how
// many cores it happened to get on a shared machine (SGBM's 3-way mode runs on a thread pool).
double ProcessCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

// ---- the rig: rectification and the rectified left camera's pose on the base ----
struct Rig {
  epmap::stereo::Rectifier rectifier;
  epmap::stereo::RectifiedGeometry geometry;
  Eigen::Isometry3d T_cam0_rect = Eigen::Isometry3d::Identity();  // raw cam0 -> rectified
};

Rig MakeRig(const Dataset& d) {
  const auto& c0 = d.cam0;
  const auto& c1 = d.cam1;
  const cv::Matx33d k0(c0.fu, 0, c0.cu, 0, c0.fv, c0.cv, 0, 0, 1);
  const cv::Matx33d k1(c1.fu, 0, c1.cu, 0, c1.fv, c1.cv, 0, 0, 1);
  epmap::stereo::CameraParameters left, right;
  Rig rig;
  if (d.rectified()) {
    std::tie(left, right) = epmap::camera::RectifiedPinholePair(c0.pinhole(), d.baseline_m());
  } else {
    cv::Matx44d tl, tr;
    for (int i = 0; i < 16; ++i) {
      tl.val[i] = c0.T_BS(i / 4, i % 4);
      tr.val[i] = c1.T_BS(i / 4, i % 4);
    }
    epmap::stereo::StereoRectifyFromExtrinsics(k0, c0.distortion, k1, c1.distortion, tl, tr,
                                               cv::Size(c0.width, c0.height), c0.distortion_model,
                                               &left, &right);
    // x_rect = R1 x_raw: the rectified frame's pose in the raw camera frame is R1^T.
    Eigen::Matrix3d r1;
    for (int i = 0; i < 9; ++i) r1(i / 3, i % 3) = left.r[static_cast<size_t>(i)];
    rig.T_cam0_rect.linear() = r1.transpose();
  }
  rig.rectifier = epmap::stereo::Rectifier(left, right);
  rig.geometry = rig.rectifier.geometry();
  return rig;
}

// ---- frames, rectified and grey ----
struct Frame {
  int64_t stamp_ns = 0;
  cv::Mat left, right;
  cv::Mat gt_disparity, gt_unexpected;
  std::optional<Eigen::Isometry3d> gt_T_world_cam0;  // when the dataset has it for this frame
  std::vector<Eigen::Vector3d> gt_movers;            // centres (world frame), gt_movers0
};

cv::Mat Grey(const cv::Mat& m) {
  if (m.channels() == 1 && m.depth() == CV_8U) return m;
  cv::Mat g = m;
  if (m.depth() == CV_16U) m.convertTo(g, CV_8U, 1.0 / 256.0);
  if (g.channels() == 3) cv::cvtColor(g, g, cv::COLOR_BGR2GRAY);
  if (g.channels() == 4) cv::cvtColor(g, g, cv::COLOR_BGRA2GRAY);
  return g;
}

Frame LoadFrame(const Dataset& d, const Rig& rig, size_t i) {
  const auto& f = d.frames[i];
  Frame out;
  out.stamp_ns = f.stamp_ns;
  const cv::Mat l = cv::imread(f.left.string(), cv::IMREAD_UNCHANGED);
  const cv::Mat r = cv::imread(f.right.string(), cv::IMREAD_UNCHANGED);
  if (l.empty() || r.empty()) {
    throw std::runtime_error("cannot read the images of frame " + std::to_string(f.stamp_ns));
  }
  rig.rectifier.Rectify(Grey(l), Grey(r), out.left, out.right);
  out.gt_disparity = epmap::dataset::LoadGtDisparity(d, f.stamp_ns);
  out.gt_unexpected = epmap::dataset::LoadGtUnexpected(d, f.stamp_ns);
  if (const auto pose = epmap::dataset::PoseAt(d.gt_camera_pose, f.stamp_ns)) {
    out.gt_T_world_cam0 = *pose;
  }
  for (auto m = std::lower_bound(
           d.gt_movers.begin(), d.gt_movers.end(), f.stamp_ns,
           [](const epmap::dataset::MoverSample&s, int64_t stamp) { return s.stamp_ns < stamp; });
       m != d.gt_movers.end() && m->stamp_ns == f.stamp_ns; ++m) {
    out.gt_movers.push_back(m->centre);
  }
  return out;
}

// ---- pose sources ----
using PoseFn = std::function<Eigen::Isometry3d(size_t frame)>;

PoseFn PoseFromSource(const Dataset& d, const Rig& rig,
                      std::shared_ptr<const epmap::internal_model::PoseSource> source) {
  return [&d, &rig, source](size_t i) {
    epmap::internal_model::PoseInput in;
    if (!d.joints.empty()) {
      const auto q = epmap::dataset::InterpolateJoints(d.joints, d.frames[i].stamp_ns);
      if (!q) {
        throw std::runtime_error("no joint reading near frame " +
                                 std::to_string(d.frames[i].stamp_ns));
      }
      in.joints = *q;
    }
    const Eigen::Isometry3d T_base_cam0 = source->CameraPose(in) * rig.T_cam0_rect;
    if (d.odometry.empty()) return T_base_cam0;
    // A mobile base: its planar pose from odometry0, then the chain (as epmapd's "odometry"
    // pose source does), so that the EP sees the base's motion too.
    const auto odom = epmap::dataset::InterpolatePlanar(d.odometry, d.frames[i].stamp_ns);
    if (!odom) {
      throw std::runtime_error("no odometry reading near frame " +
                               std::to_string(d.frames[i].stamp_ns));
    }
    return epmap::internal_model::BaseOnOdometry(odom->x, odom->y, odom->theta) * T_base_cam0;
  };
}

struct LearnedSetup {
  std::shared_ptr<const epmap::internal_model::PoseSource> source;
  epmap::internal_model::TrainingReport report;
  std::vector<std::string> inputs;
  double train_s = 0;
};

// Sec. III: 300 (theta, T) pairs from the kinematic chain over the neck range actually used
// (joints0's min..max per input joint, 5% margin), the other joints at their median reading.
LearnedSetup TrainLearned(const Dataset& d, const fs::path& save_to) {
  auto chain = epmap::kinematics::UrdfChain::FromFile(*d.urdf);
  chain.BindJointOrder(d.joint_names);
  std::vector<std::string> inputs;
  const std::vector<std::string> neck = {"neck_pitch", "neck_roll", "neck_yaw"};
  const auto column = [&](const std::string& name) {
    for (size_t i = 0; i < d.joint_names.size(); ++i) {
      if (d.joint_names[i] == name) return static_cast<int>(i);
    }
    return -1;
  };
  const bool has_neck =
      std::all_of(neck.begin(), neck.end(), [&](const std::string& n) { return column(n) >= 0; });
  inputs = has_neck ? neck : chain.joint_names();
  const size_t n_cols = d.joint_names.size();
  std::vector<double> lo(n_cols, 1e30), hi(n_cols, -1e30), median(n_cols, 0);
  for (size_t c = 0; c < n_cols; ++c) {
    std::vector<double> v;
    for (const auto& s : d.joints) v.push_back(s.positions[c]);
    lo[c] = *std::min_element(v.begin(), v.end());
    hi[c] = *std::max_element(v.begin(), v.end());
    median[c] = Median(v);
  }
  std::mt19937_64 rng(1);
  std::vector<std::vector<double>> x;
  std::vector<Eigen::Isometry3d> y;
  for (int s = 0; s < 300; ++s) {
    std::vector<double> reading = median;
    std::vector<double> q;
    for (const auto& name : inputs) {
      const int c = column(name);
      if (c < 0) throw std::runtime_error("joints0 has no column '" + name + "'");
      const double margin = 0.05 * (hi[static_cast<size_t>(c)] - lo[static_cast<size_t>(c)]);
      std::uniform_real_distribution<double> u(lo[static_cast<size_t>(c)] - margin,
                                               hi[static_cast<size_t>(c)] + margin);
      reading[static_cast<size_t>(c)] = u(rng);
      q.push_back(reading[static_cast<size_t>(c)]);
    }
    x.push_back(q);
    y.push_back(chain.Cam0Pose(reading));
  }
  const auto t0 = Clock::now();
  auto model = epmap::internal_model::LearnedPoseModel::Train(inputs, x, y);
  LearnedSetup out;
  out.train_s = std::chrono::duration<double>(Clock::now() - t0).count();
  out.report = model.report();
  out.inputs = inputs;
  if (!save_to.empty()) model.Save(save_to);
  out.source =
      std::make_shared<epmap::internal_model::LearnedPoseSource>(std::move(model), d.joint_names);
  return out;
}

// ---- one pass of the EP over the sequence ----
void Accumulate(epmap::stereo::DisparityScore* total, const epmap::stereo::DisparityScore& s) {
  total->gt_pixels += s.gt_pixels;
  total->filled += s.filled;
  total->bad_filled += s.bad_filled;
}

double Bad(const epmap::stereo::DisparityScore& s) {
  return s.gt_pixels ? s.bad_counting_unknown() : kNaN;
}

// Disparity scores summed over a sequence, its first 50 and its last 50 frames (the issue's
// "no drift": the last 50 no worse than the first 50).
struct SequenceScore {
  epmap::stereo::DisparityScore all, first, last;
  void Add(size_t frame, size_t n_frames, const epmap::stereo::DisparityScore& s) {
    Accumulate(&all, s);
    if (frame < 50) Accumulate(&first, s);
    if (frame + 50 >= n_frames) Accumulate(&last, s);
  }
};

struct PassResult {
  std::vector<double> ep_ms, full_ms, ratio, share, stereo_area;
  std::vector<double> ep_cpu_ms, full_cpu_ms, cpu_ratio;
  std::vector<double> mean_e, mean_a, mean_e_settled, mean_a_settled;
  // Settled sums of E and A split by the true unexpected mask: the static scene's residual
  // (what C should learn to attenuate) and the moving object's (what must stay bright).
  double static_e_sum = 0, static_a_sum = 0, moving_e_sum = 0, moving_a_sum = 0;
  std::vector<double> iou, flagged_not_visible;
  // Of the frames where the moving thing is visible, those with a prediction to compare (not
  // the first frame or a pose jump, computed whole), their IoU, those whose largest region
  // touching the truth exists (detected), and that region's centroid's distance on the floor
  // (world x, y) from the thing's true centre (gt_movers0).
  std::vector<double> iou_compared, mover_centroid_error_m;
  size_t visible_detected = 0;
  std::vector<double> predict_ms, compare_ms, plan_ms, stereo_ms, fuse_ms;
  std::vector<double> splat_ms, fill_ms, output_ms;  // parts of predict (output: with L_-, C_-)
  SequenceScore ep, full;
  // The same over the columns SGBM can match (RoiStereo's matchable columns): there the EP map
  // competes with full-frame SGBM on equal terms; in the left margin only the EP can know
  // anything (what it saw there before the head turned).
  SequenceScore ep_matchable, full_matchable;
  epmap::ep::EpCounters counters;
  size_t frames = 0;
};

// Writes bad-2 over the whole sequence as `name`, and over its first and last 50 frames.
void PutBad(Json* j, const std::string& name, const SequenceScore& s) {
  j->Num(name, Bad(s.all));
  j->Num(name + "_first50", Bad(s.first));
  j->Num(name + "_last50", Bad(s.last));
}

// Whether a region of `e` touches the true moving thing (largest first) and, when the dataset
// says where the thing is, how far that region's centroid lies from its centre on the floor.
void ScoreDetection(const epmap::ep::EpResult& e, const Frame& f,
                    const Eigen::Isometry3d& T_cam0_rect, PassResult* r) {
  for (const auto& region : e.regions) {
    const cv::Rect box = region.box & cv::Rect(0, 0, f.gt_unexpected.cols, f.gt_unexpected.rows);
    if (cv::countNonZero(f.gt_unexpected(box) & e.unexpected(box)) == 0) continue;
    ++r->visible_detected;
    if (region.has_centroid && f.gt_T_world_cam0 && !f.gt_movers.empty()) {
      const Eigen::Vector3d c = *f.gt_T_world_cam0 * T_cam0_rect * region.centroid_cam0;
      double best = std::numeric_limits<double>::infinity();
      for (const auto& m : f.gt_movers) best = std::min(best, (c - m).head<2>().norm());
      r->mover_centroid_error_m.push_back(best);
    }
    return;
  }
}

// Runs one EP per pose source and full-frame SGBM on the same frames, in one loop (the order
// rotates frame by frame, so that none always runs first on a warm cache); the full-frame
// figures are shared by all the passes.
std::vector<PassResult> RunPasses(const Dataset& d, const Rig& rig,
                                  const std::vector<PoseFn>& poses,
                                  const epmap::ep::EpParams& params, size_t n_frames, int settle,
                                  const fs::path& out_dir) {
  std::vector<std::unique_ptr<epmap::ep::ExpectedPerception>> eps;
  for (size_t p = 0; p < poses.size(); ++p) {
    eps.push_back(std::make_unique<epmap::ep::ExpectedPerception>(rig.geometry, params));
  }
  const epmap::stereo::SgbmMatcher full(params.sgbm);
  cv::Mat matchable;  // CV_8U 255 on the columns SGBM can match, made at the first frame
  std::vector<PassResult> results(poses.size());
  for (auto& r : results) r.frames = n_frames;
  const size_t jobs = poses.size() + 1;  // the EPs, then full SGBM
  for (size_t i = 0; i < n_frames; ++i) {
    const Frame f = LoadFrame(d, rig, i);
    std::vector<std::shared_ptr<const epmap::ep::EpResult>> res(poses.size());
    std::vector<Eigen::Isometry3d> T;
    for (const auto& pose : poses) T.push_back(pose(i));
    cv::Mat full_disp;
    double full_ms = kNaN;
    double full_cpu_ms = kNaN;
    std::vector<double> ep_cpu_ms(poses.size(), kNaN);
    for (size_t j = 0; j < jobs; ++j) {
      const size_t job = (i + j) % jobs;
      const double cpu0 = ProcessCpuMs();
      if (job == poses.size()) {
        const auto t0 = Clock::now();
        full_disp = full.Compute(f.left, f.right);
        full_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        full_cpu_ms = ProcessCpuMs() - cpu0;
      } else {
        res[job] = eps[job]->Process(f.left, f.right, T[job], f.stamp_ns);
        ep_cpu_ms[job] = ProcessCpuMs() - cpu0;
      }
    }
    if (matchable.empty() && !f.gt_disparity.empty()) {
      const epmap::ep::RoiStereo columns(params.sgbm);
      const int first = columns.first_matchable_column();
      const int last = columns.last_matchable_column(f.gt_disparity.cols);
      matchable = cv::Mat::zeros(f.gt_disparity.size(), CV_8U);
      if (last >= first) {
        matchable.colRange(first, last + 1).setTo(255);
      }
    }
    const auto full_score = f.gt_disparity.empty()
                                ? epmap::stereo::DisparityScore{}
                                : epmap::stereo::ScoreDisparity(full_disp, f.gt_disparity);
    const auto full_matchable_score =
        f.gt_disparity.empty()
            ? epmap::stereo::DisparityScore{}
            : epmap::stereo::ScoreDisparity(full_disp, f.gt_disparity, 2.0, matchable);
    for (size_t p = 0; p < poses.size(); ++p) {
      PassResult& r = results[p];
      const auto& e = *res[p];
      r.ep_ms.push_back(e.timings.total_ms);
      r.full_ms.push_back(full_ms);
      r.ratio.push_back(e.timings.total_ms / full_ms);
      r.ep_cpu_ms.push_back(ep_cpu_ms[p]);
      r.full_cpu_ms.push_back(full_cpu_ms);
      r.cpu_ratio.push_back(ep_cpu_ms[p] / full_cpu_ms);
      r.share.push_back(e.recomputed_share);
      r.stereo_area.push_back(e.stereo_area_share);
      r.predict_ms.push_back(e.timings.predict_ms);
      if (e.mode == epmap::ep::FrameMode::kPredicted) {
        r.splat_ms.push_back(e.timings.predict.splat_ms);
        r.fill_ms.push_back(e.timings.predict.fill_ms);
        r.output_ms.push_back(e.timings.predict.output_ms);
      }
      r.compare_ms.push_back(e.timings.compare_ms);
      r.plan_ms.push_back(e.timings.plan_ms);
      r.stereo_ms.push_back(e.timings.stereo_ms);
      r.fuse_ms.push_back(e.timings.fuse_ms);
      if (e.compared) {
        r.mean_e.push_back(e.mean_error);
        r.mean_a.push_back(e.mean_attenuated);
        if (static_cast<int>(i) >= settle) {
          r.mean_e_settled.push_back(e.mean_error);
          r.mean_a_settled.push_back(e.mean_attenuated);
          if (!f.gt_unexpected.empty() && !e.error.empty()) {
            // E and A are 0 where nothing was predicted, so sums compare like with like.
            cv::Mat moving;
            cv::resize(f.gt_unexpected, moving, e.error.size(), 0, 0, cv::INTER_NEAREST);
            cv::Mat weight_moving;  // 1 on the moving object, 0 elsewhere
            cv::Mat(moving > 0).convertTo(weight_moving, CV_32F, 1.0 / 255);
            const cv::Mat weight_still = 1.0 - weight_moving;
            r.static_e_sum += e.error.dot(weight_still);
            r.static_a_sum += e.attenuated.dot(weight_still);
            r.moving_e_sum += e.error.dot(weight_moving);
            r.moving_a_sum += e.attenuated.dot(weight_moving);
          }
        }
      }
      if (!f.gt_disparity.empty()) {
        const auto s = epmap::stereo::ScoreDisparity(e.disparity, f.gt_disparity);
        const auto sm = epmap::stereo::ScoreDisparity(e.disparity, f.gt_disparity, 2.0, matchable);
        r.ep.Add(i, n_frames, s);
        r.full.Add(i, n_frames, full_score);
        r.ep_matchable.Add(i, n_frames, sm);
        r.full_matchable.Add(i, n_frames, full_matchable_score);
      }
      if (!f.gt_unexpected.empty() && cv::countNonZero(f.gt_unexpected) > 0) {
        const cv::Mat truth = f.gt_unexpected > 0;
        const double inter = cv::countNonZero(truth & e.unexpected);
        const double uni = cv::countNonZero(truth | e.unexpected);
        r.iou.push_back(inter / uni);
        if (e.compared) {
          r.iou_compared.push_back(inter / uni);
          ScoreDetection(e, f, rig.T_cam0_rect, &r);
        }
      } else {
        r.flagged_not_visible.push_back(e.unexpected_share);  // nothing moves on its own
      }
      if (p == 0 && !out_dir.empty()) {
        epmap::imaging::WritePfm(out_dir / (std::to_string(f.stamp_ns) + ".pfm"), e.disparity);
        cv::imwrite((out_dir / (std::to_string(f.stamp_ns) + ".png")).string(), e.unexpected);
      }
    }
  }
  for (size_t p = 0; p < poses.size(); ++p) results[p].counters = eps[p]->counters();
  return results;
}

void Summarise(const PassResult& r, int settle, Json* j) {
  j->Int("frames", static_cast<long long>(r.frames));
  j->Num("ep_ms_median", Median(r.ep_ms));
  j->Num("full_ms_median", Median(r.full_ms));
  j->Num("ratio_median", Median(r.ratio));  // of the per-frame ratios, same frame
  j->Num("ratio_of_medians", Median(r.ep_ms) / Median(r.full_ms));
  // The mean shows what batching (border strips, refresh bands) moves out of the median frame.
  j->Num("ratio_of_means", Mean(r.ep_ms) / Mean(r.full_ms));
  // The slowest frames: what a batched refresh costs the frames that carry it.
  j->Num("ep_ms_p90", Percentile(r.ep_ms, 0.9));
  j->Num("ep_ms_max", Max(r.ep_ms));
  j->Num("full_ms_p90", Percentile(r.full_ms, 0.9));
  // The same in CPU time (all threads): robust to how many cores each part got.
  j->Num("ep_cpu_ms_median", Median(r.ep_cpu_ms));
  j->Num("full_cpu_ms_median", Median(r.full_cpu_ms));
  j->Num("cpu_ratio_median", Median(r.cpu_ratio));
  j->Num("cpu_ratio_of_means", Mean(r.ep_cpu_ms) / Mean(r.full_cpu_ms));
  j->Num("recomputed_share_median", Median(r.share));
  j->Num("recomputed_share_mean", Mean(r.share));
  j->Num("sgbm_area_share_median", Median(r.stereo_area));
  std::vector<double> after_first(r.share.begin() + (r.share.empty() ? 0 : 1), r.share.end());
  j->Num("recomputed_share_max_after_first", Max(after_first));
  PutBad(j, "bad2_ep", r.ep);
  PutBad(j, "bad2_full", r.full);
  PutBad(j, "bad2_ep_matchable", r.ep_matchable);
  PutBad(j, "bad2_full_matchable", r.full_matchable);
  j->Num("filled_share_ep", r.ep.all.gt_pixels ? r.ep.all.filled_share() : kNaN);
  j->Num("filled_share_full", r.full.all.gt_pixels ? r.full.all.filled_share() : kNaN);
  j->Int("visible_frames", static_cast<long long>(r.iou.size()));
  j->Num("iou_median", Median(r.iou));
  j->Num("iou_mean", Mean(r.iou));
  j->Int("visible_frames_compared", static_cast<long long>(r.iou_compared.size()));
  j->Num("iou_median_compared", Median(r.iou_compared));
  j->Int("visible_frames_detected", static_cast<long long>(r.visible_detected));
  if (!r.mover_centroid_error_m.empty()) {
    j->Num("mover_centroid_error_m_median", Median(r.mover_centroid_error_m));
    j->Num("mover_centroid_error_m_max", Max(r.mover_centroid_error_m));
  }
  j->Int("not_visible_frames", static_cast<long long>(r.flagged_not_visible.size()));
  j->Num("flagged_area_not_visible_mean", Mean(r.flagged_not_visible));
  j->Num("flagged_area_not_visible_median", Median(r.flagged_not_visible));
  j->Num("flagged_area_not_visible_max", Max(r.flagged_not_visible));
  j->Num("mean_E", Mean(r.mean_e));
  j->Num("mean_A", Mean(r.mean_a));
  j->Int("settle_frames", settle);
  j->Num("mean_E_settled", Mean(r.mean_e_settled));
  j->Num("mean_A_settled", Mean(r.mean_a_settled));
  j->Num("A_over_E_settled", Mean(r.mean_a_settled) / Mean(r.mean_e_settled));
  if (r.static_e_sum > 0) {
    j->Num("A_over_E_settled_static", r.static_a_sum / r.static_e_sum);
  }
  if (r.moving_e_sum > 0) {
    j->Num("A_over_E_settled_moving", r.moving_a_sum / r.moving_e_sum);
  }
  Json stages;
  stages.Num("predict", Median(r.predict_ms))
      .Num("compare", Median(r.compare_ms))
      .Num("plan", Median(r.plan_ms))
      .Num("stereo", Median(r.stereo_ms))
      .Num("fuse", Median(r.fuse_ms));
  j->Raw("stage_ms_median", stages.str());
  Json predict_parts;  // over predicted frames only
  predict_parts.Num("splat", Median(r.splat_ms))
      .Num("fill", Median(r.fill_ms))
      .Num("output", Median(r.output_ms));
  j->Raw("predict_ms_median", predict_parts.str());
  Json c;
  c.Int("predicted", static_cast<long long>(r.counters.predicted))
      .Int("full_first", static_cast<long long>(r.counters.full_first))
      .Int("full_scheduled", static_cast<long long>(r.counters.full_scheduled))
      .Int("full_share", static_cast<long long>(r.counters.full_share))
      .Int("pose_jumps", static_cast<long long>(r.counters.pose_jumps))
      .Int("from_earlier_view", static_cast<long long>(r.counters.from_earlier_view))
      .Int("non_finite_rejected", static_cast<long long>(r.counters.non_finite_rejected));
  j->Raw("frame_modes", c.str());
}

double RelDiff(double a, double b) {
  return std::isfinite(a) && std::isfinite(b) && b != 0 ? (a - b) / std::abs(b) : kNaN;
}

int Run(int argc, char** argv) {
  CLI::App app("Expected-perception disparity map vs full-frame SGBM on a dataset", argv[0]);
  std::string dataset_path, out_path, internal_model = "urdf";
  int num_disparities = 0, frames_limit = 0, settle = 30;
  bool json = false;
  std::vector<std::string> settings;
  app.add_option("--dataset", dataset_path, "dataset folder (see dataset-layout.md)")->required();
  app.add_option("--out", out_path, "write <timestamp>.pfm (EP disparity) and .png (unexpected)");
  app.add_flag("--json", json, "print only the JSON result (one line)");
  app.add_option("--num-disparities", num_disparities, "SGBM disparity range (multiple of 16)");
  app.add_option("--frames", frames_limit, "use only the first N frames");
  app.add_option("--settle-frames", settle, "frames before C counts as settled (default 30)");
  app.add_option("--internal-model", internal_model,
                 "urdf, or learned: also train the paper's MLP and run the EP with it")
      ->check(CLI::IsMember({"urdf", "learned"}));
  app.add_option("--set", settings, "EP parameter KEY=VALUE (repeatable; see --list-params)");
  bool list = false;
  app.add_flag("--list-params", list, "print the EP parameters and their defaults");
  CLI11_PARSE(app, argc, argv);
  try {
    epmap::ep::EpParams params;
    if (list) {
      for (const auto& [k, v] : epmap::ep::ListEpParams(params)) std::cout << k << "=" << v << "\n";
      return 0;
    }
    const Dataset d = epmap::dataset::Load(dataset_path);
    if (d.frames.empty()) throw std::runtime_error("the dataset has no stereo frames");
    if (num_disparities > 0) {
      params.sgbm.num_disparities = num_disparities;
    } else if (d.num_disparities > 0) {
      params.sgbm.num_disparities = d.num_disparities;
    }
    for (const auto& s : settings) {
      const auto eq = s.find('=');
      if (eq == std::string::npos) throw std::invalid_argument("--set expects KEY=VALUE: " + s);
      epmap::ep::SetEpParam(&params, s.substr(0, eq), s.substr(eq + 1));
    }
    params.Validate();
    const Rig rig = MakeRig(d);
    const size_t n = frames_limit > 0
                         ? std::min<size_t>(static_cast<size_t>(frames_limit), d.frames.size())
                         : d.frames.size();
    fs::path out_dir;
    if (!out_path.empty()) {
      out_dir = out_path;
      fs::create_directories(out_dir);
    }

    // The primary pose source: the URDF chain when there are kinematics and readings.
    std::shared_ptr<const epmap::internal_model::PoseSource> source;
    std::string source_note;
    if (d.urdf && !d.joints.empty()) {
      source = std::make_shared<epmap::internal_model::UrdfPoseSource>(
          epmap::kinematics::UrdfChain::FromFile(*d.urdf), d.joint_names);
    } else {
      source =
          std::make_shared<epmap::internal_model::FixedPoseSource>(Eigen::Isometry3d(d.cam0.T_BS));
      source_note = d.urdf ? "kinematics.urdf without joints0: fixed rig"
                           : "no kinematics.urdf: fixed rig (T_BS)";
    }
    if (internal_model == "learned" && source->Name() != "urdf") {
      throw std::invalid_argument(
          "--internal-model learned needs mav0/kinematics.urdf and joints0 to learn from");
    }
    if (!json) {
      std::cerr << "epmap-bench ep: " << n << " frames " << rig.geometry.width << "x"
                << rig.geometry.height << ", pose source " << source->Name()
                << (d.odometry.empty() ? "" : " on the base's odometry0")
                << (source_note.empty() ? "" : " (" + source_note + ")")
                << (rig.rectifier.identity() ? "" : ", rectifying") << "\n";
    }
    std::vector<PoseFn> poses = {PoseFromSource(d, rig, source)};
    LearnedSetup learned;
    if (internal_model == "learned") {
      learned = TrainLearned(d, out_dir.empty() ? fs::path() : out_dir / "learned_model.yml");
      poses.push_back(PoseFromSource(d, rig, learned.source));
    }
    const std::vector<PassResult> passes = RunPasses(d, rig, poses, params, n, settle, out_dir);
    const PassResult& main = passes.front();

    Json j;
    j.Str("command", "ep").Str("dataset", dataset_path);
    j.Int("width", rig.geometry.width).Int("height", rig.geometry.height);
    j.Int("num_disparities", params.sgbm.num_disparities);
    j.Str("pose_source", source->Name());
    j.Bool("base_odometry", !d.odometry.empty());
    j.Bool("rectified_here", !rig.rectifier.identity());
    Summarise(main, settle, &j);

    if (internal_model == "learned") {
      const PassResult& lr = passes[1];
      Json l;
      std::string inputs;
      for (const auto& s : learned.inputs) inputs += (inputs.empty() ? "" : ",") + s;
      l.Str("inputs", inputs);
      l.Int("train_samples", static_cast<long long>(learned.report.train_samples));
      l.Int("epochs", learned.report.epochs);
      l.Bool("reached_target", learned.report.reached_target);
      l.Num("train_error", learned.report.train_error);
      l.Num("validation_error", learned.report.validation_error);
      l.Num("test_error", learned.report.test_error);
      l.Num("test_rotation_rms_rad", learned.report.test_rotation_rms_rad);
      l.Num("test_translation_rms_m", learned.report.test_translation_rms_m);
      l.Num("train_s", learned.train_s);
      Summarise(lr, settle, &l);
      Json rel;
      rel.Num("ep_ms_median", RelDiff(Median(lr.ep_ms), Median(main.ep_ms)));
      rel.Num("recomputed_share_median", RelDiff(Median(lr.share), Median(main.share)));
      rel.Num("bad2_ep", RelDiff(Bad(lr.ep.all), Bad(main.ep.all)));
      rel.Num("iou_median", RelDiff(Median(lr.iou), Median(main.iou)));
      rel.Num("flagged_area_not_visible_mean",
              RelDiff(Mean(lr.flagged_not_visible), Mean(main.flagged_not_visible)));
      rel.Num("mean_A_settled", RelDiff(Mean(lr.mean_a_settled), Mean(main.mean_a_settled)));
      l.Raw("relative_to_urdf", rel.str());
      j.Raw("learned", l.str());
    }
    std::cout << j.str() << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "epmap-bench ep: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

EPMAP_BENCH_COMMAND(ep, "ep", "expected-perception map vs full-frame SGBM (speed, bad-2, IoU)",
                    Run);
