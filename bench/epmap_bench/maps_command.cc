// epmap-bench maps --dataset DIR --out DIR [--json] [--compare PMAP_JSON]: runs a mobile-base
// dataset (odometry0, joints0 with the pan joint, kinematics.urdf, rectified or not) through
// the code the service runs (perception/mobile_mapping: the perceptual map of paper 003, the
// fuzzy occupancy grid and the heading/position correction of paper 002) and writes:
//   pmap.json   {"segments":[{"id","x1","y1","x2","y2"}],"path":[[x,y]],"boundary":[[x,y]],...}
//   grid.pgm + grid.yaml   the combined occupancy grid in the ROS map_server layout
//   poses.csv   #timestamp [ns],x [m],y [m],theta [rad]  (corrected pose per key frame)
//   pmap.svg, grid.png     pictures to judge by eye (true walls underneath when known)
// World frame = the robot's start pose (the odometry frame). With ground truth (gt_base_pose0,
// gt_map/walls.csv) it prints the figures: final heading and position error of the raw
// odometry and of the corrected pose, wall coverage and stray length of the perceptual map,
// IoU of the grid's occupied cells with the rasterised walls (with and without the heading
// correction), and the per-key-frame time of both maps beside full-frame SGBM on the same frames.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bench/epmap_bench/command_registry.h"
#include "bench/epmap_bench/summary.h"
#include "common/dataset/dataset.h"
#include "perception/ep/expected_perception.h"
#include "perception/internal_model/pose_source.h"
#include "perception/kinematics/urdf_chain.h"
#include "perception/mobile_mapping/joint_limits.h"
#include "perception/mobile_mapping/key_frame_selector.h"
#include "perception/mobile_mapping/map_evaluation.h"
#include "perception/mobile_mapping/mobile_mapper.h"
#include "perception/occupancy/map_export.h"
#include "perception/perceptual_map/map_window.h"
#include "perception/stereo/rectification.h"
#include "perception/stereo/sgbm.h"

namespace {

namespace fs = std::filesystem;
using namespace epmap::bench;
using epmap::localisation::HeadingOf;
using epmap::localisation::MakePose;
using epmap::localisation::WrapAngle;
using epmap::mobile_mapping::Segment2;

constexpr double kDeg = 180.0 / std::numbers::pi;

// The dataset turned into what the mapper consumes: the rectified rig, the camera on the base
// for each frame, odometry at each frame, and which frames are key frames.
struct Prepared {
  epmap::dataset::Dataset data;
  epmap::stereo::RectifiedGeometry camera;
  std::optional<epmap::stereo::Rectifier> rectifier;
  Eigen::Isometry3d T_cam0_rect = Eigen::Isometry3d::Identity();
  std::vector<epmap::mobile_mapping::JointLimit> limits;
  struct Frame {
    size_t index;  // into data.frames
    Eigen::Isometry2d T_odom_base;
    Eigen::Isometry3d T_base_cam;  // rectified left camera
    std::vector<double> joints;    // chain joints, in the order of limits
  };
  std::vector<Frame> key_frames;
  std::vector<Frame> posed_frames;  // every frame with odometry and joints (the EP sees them all)
  size_t frames_without_odometry = 0;
  size_t frames_without_joints = 0;
  bool panning_stops = false;
  // --true-depth: the map points take their depth from gt_disparity0 (KeyFrame::true_disparity).
  bool true_depth = false;
};

// --true-depth needs the true disparity of every key frame in the rectified left image.
void CheckTrueDepth(const Prepared& p) {
  if (p.rectifier) {
    throw std::runtime_error(
        "--true-depth: gt_disparity0 is only defined for rigs whose images are already "
        "rectified");
  }
  for (const auto& f : p.key_frames) {
    const int64_t t = p.data.frames[f.index].stamp_ns;
    if (!p.data.gt_disparity.count(t)) {
      throw std::runtime_error("--true-depth: key frame " + std::to_string(t) +
                               " has no gt_disparity0 (record with epmap-sim record "
                               "--disparity-every-frame)");
    }
  }
}

Prepared Prepare(const std::string& path, size_t max_frames) {
  Prepared p;
  p.data = epmap::dataset::Load(path);
  auto& d = p.data;
  if (d.kind != epmap::dataset::Dataset::Kind::kSequence || d.odometry.empty()) {
    throw std::runtime_error(path + ": the maps benchmark needs a sequence with odometry0/");
  }
  // Rectification: already rectified rigs pass through; others as a ROS driver would do it.
  if (d.rectified()) {
    p.camera = {d.cam0.width, d.cam0.height, d.cam0.fu,     d.cam0.fv,
                d.cam0.cu,    d.cam0.cv,     d.baseline_m()};
  } else {
    epmap::stereo::CameraParameters l, r;
    const cv::Matx33d kl(d.cam0.fu, 0, d.cam0.cu, 0, d.cam0.fv, d.cam0.cv, 0, 0, 1);
    const cv::Matx33d kr(d.cam1.fu, 0, d.cam1.cu, 0, d.cam1.fv, d.cam1.cv, 0, 0, 1);
    cv::Matx44d tl, tr;
    for (int i = 0; i < 16; ++i) {
      tl.val[i] = d.cam0.T_BS(i / 4, i % 4);
      tr.val[i] = d.cam1.T_BS(i / 4, i % 4);
    }
    epmap::stereo::StereoRectifyFromExtrinsics(kl, d.cam0.distortion, kr, d.cam1.distortion, tl, tr,
                                               cv::Size(d.cam0.width, d.cam0.height),
                                               d.cam0.distortion_model, &l, &r);
    p.rectifier.emplace(l, r);
    p.camera = p.rectifier->geometry();
    // x_rect = R x_cam0: the rectified camera is cam0 turned by R^T.
    Eigen::Matrix3d R;
    for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = l.r[static_cast<size_t>(i)];
    p.T_cam0_rect.linear() = R.transpose();
  }
  std::optional<epmap::kinematics::UrdfChain> chain;
  if (d.urdf) {
    chain.emplace(epmap::kinematics::UrdfChain::FromFile(*d.urdf));
    if (!chain->joint_names().empty()) {
      chain->BindJointOrder(d.joint_names);
      p.limits = epmap::mobile_mapping::JointLimitsFromUrdfFile(*d.urdf, chain->joint_names());
    }
  }
  epmap::mobile_mapping::KeyFrameSelector selector;
  std::optional<Prepared::Frame> previous_key;
  for (size_t i = 0; i < d.frames.size() && p.key_frames.size() < max_frames; ++i) {
    const int64_t t = d.frames[i].stamp_ns;
    const auto odo = epmap::dataset::InterpolatePlanar(d.odometry, t);
    if (!odo) {
      ++p.frames_without_odometry;
      continue;
    }
    Prepared::Frame f{i, MakePose(odo->x, odo->y, odo->theta), Eigen::Isometry3d::Identity(), {}};
    Eigen::Isometry3d T_base_cam0(d.cam0.T_BS);
    if (chain && !chain->joint_names().empty()) {
      const auto q = epmap::dataset::InterpolateJoints(d.joints, t);
      if (!q) {
        ++p.frames_without_joints;
        continue;
      }
      T_base_cam0 = chain->Cam0Pose(*q);
      for (const auto& name : chain->joint_names()) {
        const auto it = std::find(d.joint_names.begin(), d.joint_names.end(), name);
        f.joints.push_back((*q)[static_cast<size_t>(it - d.joint_names.begin())]);
      }
    } else if (chain) {
      T_base_cam0 = chain->Cam0Pose({});
    }
    f.T_base_cam = T_base_cam0 * p.T_cam0_rect;
    p.posed_frames.push_back(f);
    if (!selector.Consider(f.T_odom_base, f.T_base_cam)) continue;
    if (previous_key) {
      const Eigen::Isometry2d step = previous_key->T_odom_base.inverse() * f.T_odom_base;
      const Eigen::AngleAxisd head(previous_key->T_base_cam.linear().transpose() *
                                   f.T_base_cam.linear());
      if (step.translation().norm() < 0.005 && std::abs(head.angle()) > 0.05) {
        p.panning_stops = true;
      }
    }
    previous_key = f;
    p.key_frames.push_back(f);
  }
  if (p.key_frames.empty()) throw std::runtime_error(path + ": no frame has odometry");
  return p;
}

cv::Mat ReadRectifiedLeft(const Prepared& p, size_t index, cv::Mat* right_out) {
  const auto& frame = p.data.frames[index];
  cv::Mat left = cv::imread(frame.left.string(), cv::IMREAD_GRAYSCALE);
  cv::Mat right = cv::imread(frame.right.string(), cv::IMREAD_GRAYSCALE);
  if (p.rectifier && !left.empty() && !right.empty()) {
    cv::Mat l, r;
    p.rectifier->Rectify(left, right, l, r);
    left = l;
    right = r;
  }
  *right_out = right;
  return left;
}

// What the service does before its maps see a key frame: the EP runs on every frame (camera on
// the odometry, as epmapd's mobile-base mode) and what it finds moving on its own in a key
// frame stays out of the maps (KeyFrame::moving). Returns the key frames' masks by frame index.
struct MotionMasks {
  std::map<size_t, cv::Mat> by_frame;
  std::vector<double> ep_ms;
  size_t frames = 0;
};

MotionMasks RunExpectedPerception(const Prepared& p) {
  MotionMasks out;
  std::set<size_t> key_indices;
  for (const auto& f : p.key_frames) key_indices.insert(f.index);
  epmap::ep::ExpectedPerception ep(p.camera, epmap::ep::EpParams{});
  for (const auto& f : p.posed_frames) {
    if (f.index > p.key_frames.back().index) break;
    cv::Mat right;
    const cv::Mat left = ReadRectifiedLeft(p, f.index, &right);
    if (left.empty() || right.empty()) continue;
    const auto T_odom_base = epmap::internal_model::BaseOnOdometry(
        f.T_odom_base.translation().x(), f.T_odom_base.translation().y(), HeadingOf(f.T_odom_base));
    const auto r =
        ep.Process(left, right, T_odom_base * f.T_base_cam, p.data.frames[f.index].stamp_ns);
    ++out.frames;
    out.ep_ms.push_back(r->timings.total_ms);
    if (key_indices.count(f.index) && r->unexpected_share > 0) {
      out.by_frame[f.index] = epmap::mobile_mapping::GrowMovingMask(r->unexpected);
    }
  }
  return out;
}

// Medians of the first, second, third and last quarter of the samples, in run order, as a
// JSON array: whether a cost grows as the maps do over a long run.
std::string MediansByQuarter(const std::vector<double>& v) {
  std::string out = "[";
  for (size_t q = 0; q < 4; ++q) {
    const std::vector<double> part(v.begin() + static_cast<std::ptrdiff_t>(v.size() * q / 4),
                                   v.begin() + static_cast<std::ptrdiff_t>(v.size() * (q + 1) / 4));
    out += (q ? "," : "") + FormatFixed(Median(part), 2);
  }
  return out + "]";
}

struct RunResult {
  std::shared_ptr<const epmap::mobile_mapping::MapsSnapshot> maps;
  std::vector<epmap::mobile_mapping::KeyFrameReport> reports;
  std::vector<double> key_frame_ms;
  std::vector<double> snapshot_ms;  // building the readers' snapshot after a key frame
  // A reader's first look at that snapshot's perceptual map (built on read: its boundary,
  // paper 003 III-D, grows with the map), on the reader's thread in epmapd.
  std::vector<double> snapshot_read_ms;
  // Where the base is not standing at a stop (epmapd's stage maps.snapshot): Snapshot() as it
  // is, and the same built from scratch (the perceptual map recomputed, as before it was kept
  // between changes, and the grid's cells copied, as before copies shared them), in the same
  // run.
  std::vector<double> committed_snapshot_ms, recomputed_snapshot_ms;
  std::vector<double> sgbm_ms;
  // The maps as epmapd saves them at the end of the run (maps.persist): size, time to save
  // and to restore, and whether a restored mapper saves the very same bytes.
  size_t state_bytes = 0;
  std::vector<double> save_ms, restore_ms;
  bool state_round_trip_exact = false;
};

RunResult Run(const Prepared& p, epmap::mobile_mapping::MobileMapperParams params, bool time_sgbm,
              const MotionMasks& masks) {
  params.joint_limits = p.limits;
  epmap::mobile_mapping::MobileMapper mapper(p.camera, params);
  std::optional<epmap::stereo::SgbmMatcher> sgbm;
  if (time_sgbm) sgbm.emplace(epmap::stereo::SgbmParams{});
  RunResult out;
  for (const auto& f : p.key_frames) {
    const auto& frame = p.data.frames[f.index];
    cv::Mat right;
    const cv::Mat left = ReadRectifiedLeft(p, f.index, &right);
    epmap::mobile_mapping::KeyFrame kf;
    kf.stamp_ns = frame.stamp_ns;
    kf.left = left;
    kf.right = right;
    kf.T_odom_base = f.T_odom_base;
    kf.T_base_cam = f.T_base_cam;
    kf.joint_positions = f.joints;
    if (const auto it = masks.by_frame.find(f.index); it != masks.by_frame.end()) {
      kf.moving = it->second;
    }
    if (p.true_depth) kf.true_disparity = epmap::dataset::LoadGtDisparity(p.data, frame.stamp_ns);
    const auto t0 = std::chrono::steady_clock::now();
    out.reports.push_back(mapper.AddKeyFrame(kf));
    const auto t1 = std::chrono::steady_clock::now();
    out.key_frame_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    if (time_sgbm) {
      // What the service does after each key frame: publish an immutable snapshot, with the
      // stop under way merged provisionally while the base stands there.
      const bool standing = mapper.standing_at_stop();
      const auto s0 = std::chrono::steady_clock::now();
      const auto snapshot = mapper.SnapshotWithOpenStop();
      out.snapshot_ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s0).count());
      const auto r0 = std::chrono::steady_clock::now();
      (void)snapshot->perceptual();
      out.snapshot_read_ms.push_back(MsSince(r0));
      if (!standing) {
        auto c0 = std::chrono::steady_clock::now();
        (void)mapper.Snapshot();
        out.committed_snapshot_ms.push_back(MsSince(c0));
        c0 = std::chrono::steady_clock::now();
        auto rebuilt = std::make_shared<epmap::mobile_mapping::MapsSnapshot>();
        rebuilt->perceptual_on_read =
            std::make_shared<const epmap::mobile_mapping::PerceptualMapOnRead>(mapper.perceptual());
        (void)rebuilt->perceptual();  // built now: the map recomputed, as before it was kept
        rebuilt->grid = mapper.grid().DeepCopy();
        rebuilt->poses = mapper.poses().records();
        rebuilt->counters = mapper.counters();
        out.recomputed_snapshot_ms.push_back(MsSince(c0));
      }
    }
    if (sgbm && !left.empty()) {
      const auto s0 = std::chrono::steady_clock::now();
      (void)sgbm->Compute(left, right);
      out.sgbm_ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s0).count());
    }
  }
  mapper.Flush();
  out.maps = mapper.Snapshot();
  if (time_sgbm) {
    std::string saved;
    for (int i = 0; i < 5; ++i) {
      const auto s0 = std::chrono::steady_clock::now();
      saved = mapper.SaveState();
      out.save_ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s0).count());
      epmap::mobile_mapping::MobileMapper restored(p.camera, params);
      const auto r0 = std::chrono::steady_clock::now();
      const bool ok = restored.RestoreState(saved, nullptr);
      out.restore_ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - r0).count());
      out.state_round_trip_exact = ok && restored.SaveState() == saved;
    }
    out.state_bytes = saved.size();
  }
  return out;
}

// Ground truth in the world frame of the run (the robot's start pose = odometry frame):
// T_start_gt maps the ground truth's world into it, fixed at the first key frame.
struct Truth {
  bool has_pose = false;
  Eigen::Isometry2d T_start_gt = Eigen::Isometry2d::Identity();
  Eigen::Isometry2d T_gt_start = Eigen::Isometry2d::Identity();
  std::vector<Segment2> walls;      // start frame
  std::vector<Segment2> furniture;  // start frame (gt_map/furniture.csv, when the dataset has it)
};

// gt_map/furniture.csv (an extension of epmap-sim): footprints of furniture, as walls.csv.
std::vector<Segment2> ReadFurniture(const fs::path& root) {
  std::vector<Segment2> out;
  std::ifstream in(root / "mav0" / "gt_map" / "furniture.csv");
  std::string line;
  while (std::getline(in, line)) {
    double x1, y1, x2, y2;
    if (std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf", &x1, &y1, &x2, &y2) == 4) {
      out.push_back({{x1, y1}, {x2, y2}});
    }
  }
  return out;
}

Truth MakeTruth(const Prepared& p) {
  Truth t;
  const auto& d = p.data;
  if (d.gt_base_pose.empty()) return t;
  const auto& first = p.key_frames.front();
  const auto gt = epmap::dataset::InterpolatePlanar(d.gt_base_pose, d.frames[first.index].stamp_ns);
  if (!gt) return t;
  t.has_pose = true;
  // T_gt_odom = T_gt_base(t0) * T_odom_base(t0)^-1.
  t.T_gt_start = MakePose(gt->x, gt->y, gt->theta) * first.T_odom_base.inverse();
  t.T_start_gt = t.T_gt_start.inverse();
  for (const auto& w : d.walls) {
    t.walls.push_back(
        {t.T_start_gt * Eigen::Vector2d(w.x1, w.y1), t.T_start_gt * Eigen::Vector2d(w.x2, w.y2)});
  }
  for (const auto& f : ReadFurniture(d.root)) {
    t.furniture.push_back({t.T_start_gt * f.a, t.T_start_gt * f.b});
  }
  return t;
}

struct PoseErrors {
  double heading_deg = std::nan("");
  double position_m = std::nan("");
};

// The true base pose at a stamp in the map's world (the robot's start pose), when known.
std::optional<Eigen::Isometry2d> TrueBasePose(const Prepared& p, const Truth& truth,
                                              int64_t stamp) {
  const auto gt = epmap::dataset::InterpolatePlanar(p.data.gt_base_pose, stamp);
  if (!truth.has_pose || !gt) return std::nullopt;
  return truth.T_start_gt * MakePose(gt->x, gt->y, gt->theta);
}

PoseErrors FinalErrors(const Prepared& p, const Truth& truth, const Eigen::Isometry2d& estimate,
                       int64_t stamp) {
  PoseErrors e;
  const auto truth_pose = TrueBasePose(p, truth, stamp);
  if (!truth_pose) return e;
  const Eigen::Isometry2d& T = *truth_pose;
  e.heading_deg = std::abs(WrapAngle(HeadingOf(estimate) - HeadingOf(T))) * kDeg;
  e.position_m = (estimate.translation() - T.translation()).norm();
  return e;
}

// Position error of every key frame's pose against the truth (the final error alone
// hides a trajectory that wanders and comes back).
std::vector<double> PositionErrors(const Prepared& p, const Truth& truth,
                                   const std::vector<epmap::localisation::PoseRecord>& poses,
                                   bool odometry) {
  std::vector<double> out;
  for (const auto& r : poses) {
    const auto& estimate = odometry ? r.T_world_base_odometry : r.T_world_base;
    const double e = FinalErrors(p, truth, estimate, r.stamp_ns).position_m;
    if (std::isfinite(e)) out.push_back(e);
  }
  return out;
}

// The correlation's shifts checked against the truth: for each applied shift, the true position
// error at the stop it corrected, before and after (the stop's pose in the final trajectory is the
// one right after its shift: later shifts move only later poses).
struct ShiftCheck {
  size_t applied = 0, toward_truth = 0;
  std::vector<double> error_before_m, error_after_m;
};

ShiftCheck CheckShifts(const Prepared& p, const Truth& truth,
                       const std::vector<epmap::mobile_mapping::KeyFrameReport>& reports,
                       const std::vector<epmap::localisation::PoseRecord>& poses) {
  ShiftCheck c;
  size_t k = 0;  // pose record of the next accepted key frame
  for (const auto& r : reports) {
    if (!r.accepted) continue;
    // The shift is reported by the key frame that closed the stop: the stop's last key frame is
    // the accepted one before it.
    if (r.shifted && k > 0 && k - 1 < poses.size()) {
      const auto& stop = poses[k - 1];
      if (const auto truth_pose = TrueBasePose(p, truth, stop.stamp_ns)) {
        const Eigen::Vector2d after = stop.T_world_base.translation() - truth_pose->translation();
        const Eigen::Vector2d before = after - r.shift_m;
        ++c.applied;
        c.toward_truth += after.norm() < before.norm();
        c.error_before_m.push_back(before.norm());
        c.error_after_m.push_back(after.norm());
      }
    }
    ++k;
  }
  return c;
}

std::vector<Segment2> ToSegments(const std::vector<epmap::perceptual_map::MapSegment>& segments) {
  std::vector<Segment2> out;
  for (const auto& s : segments) out.push_back({s.a, s.b});
  return out;
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path.string());
  out << text;
}

// What a local planner polls (GetOccupancyGrid with around_robot_m): the square of side_m
// around the final corrected pose, against the whole grid's export (the baseline) on the same
// snapshot, each `repeat` times. Throws if a window cell differs from the whole grid's.
std::string GridWindowJson(const epmap::mobile_mapping::MapsSnapshot& maps, double side_m,
                           int repeat) {
  if (maps.poses.empty()) return "null";  // no key frame: no robot to centre on
  const auto& grid = maps.grid;
  const Eigen::Vector2d at = maps.poses.back().T_world_base.translation();
  const auto window =
      epmap::occupancy::WindowOverBox(grid.resolution(), at.x() - side_m / 2, at.y() - side_m / 2,
                                      at.x() + side_m / 2, at.y() + side_m / 2);
  std::vector<double> window_ms, whole_ms;
  epmap::occupancy::GridExport part, whole;
  for (int k = 0; k < repeat; ++k) {
    auto t0 = std::chrono::steady_clock::now();
    whole = grid.Export();
    whole_ms.push_back(MsSince(t0));
    t0 = std::chrono::steady_clock::now();
    part = grid.ExportWindow(window);
    window_ms.push_back(MsSince(t0));
  }
  // The window's cells are the whole grid's, or unknown where it has none.
  const double res = grid.resolution();
  const long dc = std::lround((part.origin_x - whole.origin_x) / res);
  const long dr = std::lround((part.origin_y - whole.origin_y) / res);
  size_t differ = 0;
  for (long r = 0; r < static_cast<long>(part.height); ++r) {
    for (long c = 0; c < static_cast<long>(part.width); ++c) {
      const long wc = c + dc, wr = r + dr;
      const bool in = wc >= 0 && wr >= 0 && wc < static_cast<long>(whole.width) &&
                      wr < static_cast<long>(whole.height);
      const size_t i = static_cast<size_t>(r) * part.width + static_cast<size_t>(c);
      const uint8_t expected =
          in ? whole.occupancy[static_cast<size_t>(wr) * whole.width + static_cast<size_t>(wc)]
             : epmap::occupancy::GridExport::kUnknown;
      differ += part.occupancy[i] != expected;
    }
  }
  if (differ > 0) {
    throw std::runtime_error("grid window: " + std::to_string(differ) +
                             " cells differ from the whole grid's");
  }
  std::ostringstream j;
  j << "{\"side_m\":" << FormatFixed(side_m, 1) << ",\"cells\":" << part.occupancy.size()
    << ",\"bytes\":" << 2 * part.occupancy.size()
    << ",\"ms_median\":" << FormatFixed(Median(window_ms), 3)
    << ",\"baseline\":\"the whole grid's export (GetOccupancyGrid without a window)\""
    << ",\"baseline_cells\":" << whole.occupancy.size()
    << ",\"baseline_bytes\":" << 2 * whole.occupancy.size()
    << ",\"baseline_ms_median\":" << FormatFixed(Median(whole_ms), 3)
    << ",\"ratio_to_baseline\":" << FormatFixed(Median(window_ms) / Median(whole_ms), 3)
    << ",\"repeat\":" << repeat << "}";
  return j.str();
}

// The perceptual map's window (GetPerceptualMapRequest around_robot_m): how many of the map's
// segments a local planner gets around the final pose, against the whole map it would get
// without one.
std::string PmapWindowJson(const epmap::mobile_mapping::MapsSnapshot& maps, double side_m,
                           int repeat) {
  if (maps.poses.empty()) return "null";
  const Eigen::Vector2d at = maps.poses.back().T_world_base.translation();
  const Eigen::AlignedBox2d box(at - Eigen::Vector2d::Constant(side_m / 2),
                                at + Eigen::Vector2d::Constant(side_m / 2));
  const auto& segments = maps.perceptual().segments;
  std::vector<double> ms;
  std::vector<epmap::perceptual_map::MapSegment> in;
  for (int k = 0; k < repeat; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    in = epmap::perceptual_map::SegmentsInBox(segments, box);
    ms.push_back(MsSince(t0));
  }
  std::ostringstream j;
  j << "{\"side_m\":" << FormatFixed(side_m, 1) << ",\"segments\":" << in.size()
    << ",\"select_ms_median\":" << FormatFixed(Median(ms), 3)
    << ",\"baseline\":\"the whole perceptual map (GetPerceptualMap without a window)\""
    << ",\"baseline_segments\":" << segments.size() << ",\"ratio_to_baseline\":"
    << FormatFixed(segments.empty() ? 0.0 : double(in.size()) / segments.size(), 3)
    << ",\"repeat\":" << repeat << "}";
  return j.str();
}

std::string PmapJson(const epmap::perceptual_map::PerceptualMap& m, const Truth& truth) {
  std::ostringstream s;
  s << "{\"frame\":\"world = the robot's start pose\",\"segments\":[";
  for (size_t i = 0; i < m.segments.size(); ++i) {
    const auto& g = m.segments[i];
    s << (i ? "," : "") << "{\"id\":" << g.id << ",\"x1\":" << FormatFixed(g.a.x(), 4)
      << ",\"y1\":" << FormatFixed(g.a.y(), 4) << ",\"x2\":" << FormatFixed(g.b.x(), 4)
      << ",\"y2\":" << FormatFixed(g.b.y(), 4) << ",\"view\":" << g.view_id
      << ",\"observations\":" << g.observations << "}";
  }
  s << "],\"kept_ids\":[";
  for (size_t i = 0; i < m.kept_segments.size(); ++i) s << (i ? "," : "") << m.kept_segments[i].id;
  const auto points = [&](const std::vector<Eigen::Vector2d>& pts) {
    s << "[";
    for (size_t i = 0; i < pts.size(); ++i) {
      s << (i ? "," : "") << "[" << FormatFixed(pts[i].x(), 4) << "," << FormatFixed(pts[i].y(), 4)
        << "]";
    }
    s << "]";
  };
  s << "],\"path\":";
  points(m.path);
  s << ",\"boundary\":";
  points(m.boundary.outer);
  s << ",\"inner_boundary\":";
  points(m.boundary.inner);
  s << ",\"views\":[";
  for (size_t i = 0; i < m.views.size(); ++i) {
    const auto& v = m.views[i];
    s << (i ? "," : "") << "{\"id\":" << v.id << ",\"stamp_ns\":" << v.stamp_ns
      << ",\"x\":" << FormatFixed(v.T_map_base.translation().x(), 4)
      << ",\"y\":" << FormatFixed(v.T_map_base.translation().y(), 4)
      << ",\"theta\":" << FormatFixed(HeadingOf(v.T_map_base), 4) << ",\"objects\":" << v.objects
      << ",\"tracked\":" << v.tracked << ",\"in_map\":" << (v.in_map ? "true" : "false") << "}";
  }
  s << "]";
  if (truth.has_pose) {
    // Where the start pose is in the ground truth's world, to compare runs that start elsewhere.
    s << ",\"gt_start\":[" << FormatFixed(truth.T_gt_start.translation().x(), 6) << ","
      << FormatFixed(truth.T_gt_start.translation().y(), 6) << ","
      << FormatFixed(HeadingOf(truth.T_gt_start), 6) << "]";
  }
  s << "}\n";
  return s.str();
}

// Reads the segments (and gt_start, if any) of a pmap.json written by this command.
struct OtherMap {
  std::vector<Segment2> segments;
  std::optional<Eigen::Isometry2d> T_gt_start;
};

OtherMap ReadPmap(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  OtherMap m;
  const auto number_after = [&](const std::string& key, size_t from, size_t* end) {
    const size_t k = text.find("\"" + key + "\":", from);
    if (k == std::string::npos) return std::nan("");
    const size_t b = k + key.size() + 3;
    *end = b;
    return std::strtod(text.c_str() + b, nullptr);
  };
  const size_t seg_begin = text.find("\"segments\":[");
  const size_t seg_end = text.find("]", seg_begin);
  if (seg_begin == std::string::npos) throw std::runtime_error(path.string() + ": no segments");
  size_t pos = seg_begin;
  while (true) {
    const size_t obj = text.find("{", pos);
    if (obj == std::string::npos || obj > seg_end) break;
    size_t e = obj;
    Segment2 s;
    s.a.x() = number_after("x1", obj, &e);
    s.a.y() = number_after("y1", obj, &e);
    s.b.x() = number_after("x2", obj, &e);
    s.b.y() = number_after("y2", obj, &e);
    m.segments.push_back(s);
    pos = text.find("}", obj) + 1;
  }
  const size_t g = text.find("\"gt_start\":[");
  if (g != std::string::npos) {
    double x = 0, y = 0, th = 0;
    if (std::sscanf(text.c_str() + g + 12, "%lf,%lf,%lf", &x, &y, &th) == 3) {
      m.T_gt_start = MakePose(x, y, th);
    }
  }
  return m;
}

// The world box a picture of the map shows: true walls, map segments and path, plus 1 m.
std::pair<Eigen::Vector2d, Eigen::Vector2d> PictureBounds(
    const epmap::perceptual_map::PerceptualMap& m, const Truth& truth) {
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  const auto grow = [&](const Eigen::Vector2d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const auto& w : truth.walls) {
    grow(w.a);
    grow(w.b);
  }
  for (const auto& s : m.segments) {
    grow(s.a);
    grow(s.b);
  }
  for (const auto& p : m.path) grow(p);
  if (!(hi.x() > lo.x())) {
    lo = Eigen::Vector2d(-1, -1);
    hi = Eigen::Vector2d(1, 1);
  }
  lo -= Eigen::Vector2d(1, 1);
  hi += Eigen::Vector2d(1, 1);
  return {lo, hi};
}

// The perceptual map over the true walls, with path and boundary (SVG, y up).
std::string Svg(const epmap::perceptual_map::PerceptualMap& m, const Truth& truth,
                const std::vector<Eigen::Vector2d>& true_path) {
  const auto [lo, hi] = PictureBounds(m, truth);
  const double scale = 30;  // px per metre
  const auto X = [&](const Eigen::Vector2d& p) { return (p.x() - lo.x()) * scale; };
  const auto Y = [&](const Eigen::Vector2d& p) { return (hi.y() - p.y()) * scale; };
  std::ostringstream s;
  s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\""
    << FormatFixed((hi.x() - lo.x()) * scale, 0) << "\" height=\""
    << FormatFixed((hi.y() - lo.y()) * scale, 0) << "\">\n"
    << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    << "<text x=\"8\" y=\"16\" font-size=\"13\" font-family=\"sans-serif\">grey: true walls; "
       "red: perceptual map (dark red: kept after redundancy removal); blue: path; green: outer "
       "boundary; orange: inner boundary; dashed grey: true path. 1 m = 30 px</text>\n";
  const auto line = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const char* colour,
                        double width, const char* extra = "") {
    s << "<line x1=\"" << FormatFixed(X(a), 1) << "\" y1=\"" << FormatFixed(Y(a), 1) << "\" x2=\""
      << FormatFixed(X(b), 1) << "\" y2=\"" << FormatFixed(Y(b), 1) << "\" stroke=\"" << colour
      << "\" stroke-width=\"" << width << "\" " << extra << "/>\n";
  };
  const auto polyline = [&](const std::vector<Eigen::Vector2d>& pts, const char* colour,
                            double width, const char* extra = "") {
    if (pts.size() < 2) return;
    s << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"" << width << "\" "
      << extra << " points=\"";
    for (const auto& p : pts) s << FormatFixed(X(p), 1) << "," << FormatFixed(Y(p), 1) << " ";
    s << "\"/>\n";
  };
  for (const auto& w : truth.walls) line(w.a, w.b, "#bbbbbb", 4);
  polyline(true_path, "#999999", 1.5, "stroke-dasharray=\"6,4\"");
  std::vector<bool> kept;
  for (const auto& g : m.segments) {
    const bool k = std::any_of(m.kept_segments.begin(), m.kept_segments.end(),
                               [&](const auto& x) { return x.id == g.id; });
    line(g.a, g.b, k ? "#a00000" : "#ff8080", k ? 2 : 1);
  }
  polyline(m.boundary.outer, "#00a000", 1.2, "stroke-opacity=\"0.8\"");
  polyline(m.boundary.inner, "#ff9900", 1.2, "stroke-opacity=\"0.8\"");
  polyline(m.path, "#0040ff", 2);
  for (const auto& p : m.path) {
    s << "<circle cx=\"" << FormatFixed(X(p), 1) << "\" cy=\"" << FormatFixed(Y(p), 1)
      << "\" r=\"2.5\" fill=\"#0040ff\"/>\n";
  }
  if (!m.path.empty()) {
    s << "<text x=\"" << FormatFixed(X(m.path.front()) + 4, 1) << "\" y=\""
      << FormatFixed(Y(m.path.front()) - 4, 1) << "\" font-size=\"14\" fill=\"#0040ff\">S</text>\n";
    s << "<text x=\"" << FormatFixed(X(m.path.back()) + 4, 1) << "\" y=\""
      << FormatFixed(Y(m.path.back()) - 4, 1) << "\" font-size=\"14\" fill=\"#0040ff\">E</text>\n";
  }
  s << "</svg>\n";
  return s.str();
}

// The same picture as the SVG, as a PNG (20 px per metre, y up).
cv::Mat PmapPicture(const epmap::perceptual_map::PerceptualMap& m, const Truth& truth,
                    const std::vector<Eigen::Vector2d>& true_path) {
  const auto [lo, hi] = PictureBounds(m, truth);
  const double scale = 20;
  cv::Mat img(static_cast<int>((hi.y() - lo.y()) * scale),
              static_cast<int>((hi.x() - lo.x()) * scale), CV_8UC3, cv::Scalar(255, 255, 255));
  const auto px = [&](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>((p.x() - lo.x()) * scale),
                     static_cast<int>((hi.y() - p.y()) * scale));
  };
  for (const auto& w : truth.walls) cv::line(img, px(w.a), px(w.b), cv::Scalar(190, 190, 190), 3);
  for (const auto& f : truth.furniture) {
    cv::line(img, px(f.a), px(f.b), cv::Scalar(150, 200, 230), 2);
  }
  auto solid = truth.walls;
  solid.insert(solid.end(), truth.furniture.begin(), truth.furniture.end());
  for (size_t i = 1; i < true_path.size(); ++i) {
    cv::line(img, px(true_path[i - 1]), px(true_path[i]), cv::Scalar(160, 160, 160), 1);
  }
  for (const auto& g : m.segments) {
    const bool kept = std::any_of(m.kept_segments.begin(), m.kept_segments.end(),
                                  [&](const auto& x) { return x.id == g.id; });
    // Magenta: farther than 1 m from every wall and piece of furniture (stray).
    const bool stray =
        !solid.empty() && epmap::mobile_mapping::CoveredShare({{g.a, g.b}}, solid, 1.0) < 0.5;
    const cv::Scalar colour = stray  ? cv::Scalar(200, 0, 200)
                              : kept ? cv::Scalar(0, 0, 170)
                                     : cv::Scalar(128, 128, 255);
    cv::line(img, px(g.a), px(g.b), colour, 1, cv::LINE_AA);
  }
  for (size_t i = 1; i < m.boundary.outer.size(); ++i) {
    cv::line(img, px(m.boundary.outer[i - 1]), px(m.boundary.outer[i]), cv::Scalar(0, 160, 0), 1);
  }
  for (size_t i = 1; i < m.boundary.inner.size(); ++i) {
    cv::line(img, px(m.boundary.inner[i - 1]), px(m.boundary.inner[i]), cv::Scalar(0, 150, 255), 1);
  }
  for (size_t i = 1; i < m.path.size(); ++i) {
    cv::line(img, px(m.path[i - 1]), px(m.path[i]), cv::Scalar(255, 64, 0), 2);
  }
  return img;
}

cv::Mat GridPicture(const epmap::occupancy::GridExport& g, const Truth& truth,
                    const std::vector<epmap::localisation::PoseRecord>& poses) {
  const int scale = 4;
  cv::Mat img = epmap::occupancy::RenderGrid(g, scale);
  const auto px = [&](const Eigen::Vector2d& p) {
    return cv::Point(
        static_cast<int>((p.x() - g.origin_x) / g.resolution_m * scale),
        static_cast<int>(g.height * scale - (p.y() - g.origin_y) / g.resolution_m * scale));
  };
  for (const auto& w : truth.walls) {
    cv::line(img, px(w.a), px(w.b), cv::Scalar(0, 0, 230), 1, cv::LINE_AA);
  }
  for (size_t i = 1; i < poses.size(); ++i) {
    cv::line(img, px(poses[i - 1].T_world_base.translation()),
             px(poses[i].T_world_base.translation()), cv::Scalar(255, 90, 0), 1, cv::LINE_AA);
  }
  return img;
}

// `layer` (one band's export, cropped to what that band knows) on `frame`'s larger extent, the
// cells outside the band's crop unknown: scores of the bands and of the combined map then count
// the same wall cells.
epmap::occupancy::GridExport OnExtentOf(const epmap::occupancy::GridExport& layer,
                                        const epmap::occupancy::GridExport& frame) {
  epmap::occupancy::GridExport out = layer;
  out.origin_x = frame.origin_x;
  out.origin_y = frame.origin_y;
  out.width = frame.width;
  out.height = frame.height;
  out.occupancy.assign(static_cast<size_t>(frame.width) * frame.height,
                       epmap::occupancy::GridExport::kUnknown);
  out.confidence.assign(out.occupancy.size(), 0);
  const long dc = std::lround((layer.origin_x - frame.origin_x) / frame.resolution_m);
  const long dr = std::lround((layer.origin_y - frame.origin_y) / frame.resolution_m);
  for (uint32_t r = 0; r < layer.height; ++r) {
    for (uint32_t c = 0; c < layer.width; ++c) {
      const long fr = dr + r, fc = dc + c;
      if (fr < 0 || fc < 0 || fr >= static_cast<long>(frame.height) ||
          fc >= static_cast<long>(frame.width)) {
        continue;
      }
      const size_t from = static_cast<size_t>(r) * layer.width + c;
      const size_t to = static_cast<size_t>(fr) * frame.width + static_cast<size_t>(fc);
      out.occupancy[to] = layer.occupancy[from];
      out.confidence[to] = layer.confidence[from];
    }
  }
  return out;
}

int RunCommand(int argc, char** argv) {
  CLI::App app("Perceptual map + occupancy grid + heading correction over a mobile-base dataset",
               argv[0]);
  std::string dataset_path, out_dir, compare_path;
  bool json = false, no_variants = false, no_motion_mask = false, no_map_correlation = false;
  bool place_by_common_objects = false, no_grid_features = false, true_depth = false;
  int max_features = 0;
  bool reject_contested = false;
  double floor_z = 0.0;
  int view_min = 0;
  int min_tracked = 0;
  double refine_disparity = 0;
  double occupied_depth = -1;
  double grid_prior = -1;
  double grid_gap = -1, grid_gap_min = -1, grid_weight_exponent = -1;
  double grid_max_range = -1;
  double grid_resolution = 0;  // 0: the mapper's
  double min_shift = -1;
  double odometry_drift = -1;
  double heading_step_deg = -1, heading_sigma_deg = -1, heading_drift_deg = -1,
         heading_turn_drift = -1;
  size_t max_frames = 1'000'000;
  app.add_option("--dataset", dataset_path, "dataset folder with odometry0/")->required();
  app.add_option("--out", out_dir, "output folder (created)")->required();
  app.add_flag("--json", json, "print the figures as one JSON object on stdout");
  app.add_option("--compare", compare_path,
                 "pmap.json of another run of the same world (e.g. --reverse) for the shape "
                 "similarity");
  app.add_option("--floor-z", floor_z, "floor height in the base frame (m)");
  app.add_option("--view-min-key-frames", view_min,
                 "key frames a stop needs to make a view (0 = automatic, as epmapd: 1 until the "
                 "head pans at a stop, then 2)");
  app.add_option("--min-tracked", min_tracked,
                 "perceptual map: a view joins the map when fewer of the previous view's objects "
                 "are still tracked (paper 003 Sec. III-C; 0 = the default)");
  app.add_option("--refine-disparity", refine_disparity,
                 "perceptual map: refine each edge disparity within +-PX over the matching window "
                 "(EdgeStereoParams::refine_disparity_px; 0 = off, the default)");
  app.add_option("--occupied-depth", occupied_depth,
                 "occupancy grid: each point also marks occupied the cells up to M behind it "
                 "along its ray (MeasurementParams::occupied_depth_m; default: the mapper's)");
  app.add_option("--grid-max-range", grid_max_range,
                 "occupancy grid: points farther from the camera are left out of the grid "
                 "(MeasurementParams::max_range_m; default: the mapper's)");
  app.add_option("--grid-prior", grid_prior,
                 "occupancy grid: weight of the prior in the ray frequencies "
                 "(MeasurementParams::frequency_prior; default: the mapper's)");
  app.add_option("--grid-gap", grid_gap,
                 "occupancy grid: a ray stops clearing this many range sigmas before its point "
                 "(MeasurementParams::empty_gap_sigmas; default: the mapper's)");
  app.add_option("--grid-gap-min", grid_gap_min,
                 "occupancy grid: ... and at least this share of a cell before it "
                 "(MeasurementParams::empty_gap_min_cells; default: the mapper's)");
  app.add_option("--grid-resolution", grid_resolution,
                 "occupancy grid cell size in metres (GridParams::resolution_m; default: the "
                 "mapper's)");
  app.add_option("--grid-weight-exponent", grid_weight_exponent,
                 "occupancy grid: a point weighs min(1, (resolution / range sigma)^E) "
                 "(MeasurementParams::weight_exponent; default: the mapper's)");
  app.add_option("--min-shift", min_shift,
                 "map correlation: smallest correction applied, m "
                 "(MobileMapperParams::correlation_min_shift_m; default: the mapper's)");
  app.add_option("--odometry-drift", odometry_drift,
                 "map correlation: odometry's drift per metre driven, against which each "
                 "correlation shift is weighed (MobileMapperParams::odometry_drift_per_m)");
  app.add_option("--heading-step", heading_step_deg,
                 "map correlation: also try the local map turned by +-DEG about the stop and "
                 "correct the heading by the better turn (MobileMapperParams::"
                 "correlation_heading_step_rad; 0 = off; default: the mapper's)");
  app.add_option("--heading-sigma", heading_sigma_deg,
                 "map correlation: noise of one heading measurement, deg "
                 "(MobileMapperParams::correlation_heading_sigma_rad; default: the mapper's)");
  app.add_option("--heading-turn-drift", heading_turn_drift,
                 "map correlation: the visual heading's drift per angle turned (0.003 = 0.3 %; "
                 "MobileMapperParams::heading_drift_per_rad; default: the mapper's)");
  app.add_option("--heading-drift", heading_drift_deg,
                 "map correlation: the visual heading's drift, deg per metre driven "
                 "(MobileMapperParams::heading_drift_rad_per_m; default: the mapper's)");
  app.add_option("--max-key-frames", max_frames, "stop after this many key frames");
  app.add_flag("--no-variants", no_variants,
               "skip the runs without heading correction / without any correction");
  app.add_flag("--reject-contested", reject_contested,
               "perceptual map: drop edge matches whose right edge two left edges claim "
               "(EdgeStereoParams::reject_contested; off by default)");
  app.add_flag("--no-map-correlation", no_map_correlation,
               "heading correction only: no local/global map correlation at the stops (paper 002, "
               "Sec. 4), to measure what the correlation adds");
  app.add_flag("--place-by-common-objects", place_by_common_objects,
               "perceptual map: place each view's new objects from the nearest common object "
               "(paper 003 Sec. III-C) instead of by the corrected pose (PerceptualMapParams::"
               "place_by_pose off)");
  app.add_flag("--no-grid-features", no_grid_features,
               "occupancy grid: edge points only, not the corner features tracked for the heading "
               "(MobileMapperParams::occupancy_feature_points off)");
  app.add_option("--max-features", max_features,
                 "Shi-Tomasi corners per key frame, for the heading and the grid "
                 "(StereoFeatureParams::max_features; default: the mapper's)");
  app.add_flag("--true-depth", true_depth,
               "evaluation: the map points take their depth from gt_disparity0 (every key frame "
               "needs one: epmap-sim record --disparity-every-frame) where it is unambiguous, to "
               "tell what the stereo's depth error costs the maps; the heading keeps the stereo's");
  app.add_flag("--no-motion-mask", no_motion_mask,
               "do not run the EP before the maps (epmapd leaves what the EP finds moving on its "
               "own out of the maps)");
  CLI11_PARSE(app, argc, argv);
  try {
    Prepared p = Prepare(dataset_path, max_frames);
    if (true_depth) {
      CheckTrueDepth(p);
      p.true_depth = true;
    }
    fs::create_directories(out_dir);
    const Truth truth = MakeTruth(p);

    epmap::mobile_mapping::MobileMapperParams params;
    params.floor_z_in_base_m = floor_z;
    params.view_min_key_frames = view_min;  // 0: the mapper decides online, as in epmapd
    if (min_tracked != 0) params.perceptual.min_tracked = min_tracked;  // validated there
    params.edges.refine_disparity_px = refine_disparity;
    params.map_correlation = !no_map_correlation;
    if (no_grid_features) params.occupancy_feature_points = false;
    if (max_features > 0) params.features.max_features = max_features;
    if (place_by_common_objects) params.perceptual.place_by_pose = false;
    params.edges.reject_contested = reject_contested;
    if (occupied_depth >= 0) params.measurement.occupied_depth_m = occupied_depth;
    if (grid_prior >= 0) params.measurement.frequency_prior = grid_prior;
    if (grid_max_range >= 0) params.measurement.max_range_m = grid_max_range;
    if (grid_resolution != 0) params.grid.resolution_m = grid_resolution;  // validated there
    if (grid_gap >= 0) params.measurement.empty_gap_sigmas = grid_gap;
    if (grid_weight_exponent >= 0) params.measurement.weight_exponent = grid_weight_exponent;
    if (grid_gap_min >= 0) params.measurement.empty_gap_min_cells = grid_gap_min;
    if (min_shift >= 0) params.correlation_min_shift_m = min_shift;
    if (odometry_drift >= 0) params.odometry_drift_per_m = odometry_drift;
    if (heading_step_deg >= 0) params.correlation_heading_step_rad = heading_step_deg * M_PI / 180;
    if (heading_sigma_deg > 0)
      params.correlation_heading_sigma_rad = heading_sigma_deg * M_PI / 180;
    if (heading_turn_drift >= 0) params.heading_drift_per_rad = heading_turn_drift;
    if (heading_drift_deg >= 0) params.heading_drift_rad_per_m = heading_drift_deg * M_PI / 180;

    const MotionMasks masks = no_motion_mask ? MotionMasks{} : RunExpectedPerception(p);
    const RunResult main = Run(p, params, true, masks);
    const auto& maps = *main.maps;
    const auto& poses = maps.poses;
    const auto grid_export = maps.grid.Export();

    // Outputs.
    WriteText(fs::path(out_dir) / "pmap.json", PmapJson(maps.perceptual(), truth));
    WriteText(fs::path(out_dir) / "grid.pgm", epmap::occupancy::EncodePgm(grid_export));
    WriteText(fs::path(out_dir) / "grid.yaml",
              epmap::occupancy::MapServerYaml(grid_export, "grid.pgm"));
    {
      std::ostringstream csv;
      csv << "#timestamp [ns],x [m],y [m],theta [rad]\n";
      for (const auto& r : poses) {
        csv << r.stamp_ns << "," << FormatFixed(r.T_world_base.translation().x(), 6) << ","
            << FormatFixed(r.T_world_base.translation().y(), 6) << ","
            << FormatFixed(HeadingOf(r.T_world_base), 6) << "\n";
      }
      WriteText(fs::path(out_dir) / "poses.csv", csv.str());
    }
    {
      // Per key frame: where the heading change came from, against the truth when known.
      std::ostringstream csv;
      csv << "#timestamp [ns],accepted,heading_source,odometry_dtheta [rad],visual_dtheta [rad],"
             "true_dtheta [rad],edge_points,features,tracked_pairs,inliers,stop_closed,"
             "shift_x [m],shift_y [m],heading_turn [rad],x [m],y [m],theta [rad],key_frame [ms],"
             "snapshot [ms]\n";
      size_t k = 0;
      std::optional<double> prev_true;
      for (size_t i = 0; i < main.reports.size(); ++i) {
        const auto& r = main.reports[i];
        const auto& f = p.key_frames[i];
        const int64_t t = p.data.frames[f.index].stamp_ns;
        std::optional<double> true_theta;
        if (truth.has_pose) {
          const auto gt = epmap::dataset::InterpolatePlanar(p.data.gt_base_pose, t);
          if (gt) true_theta = gt->theta;
        }
        csv << t << "," << r.accepted << ",";
        if (r.accepted && k < poses.size()) {
          const auto& rec = poses[k++];
          csv << epmap::localisation::ToString(rec.heading_source) << ","
              << FormatFixed(rec.odometry_dtheta, 6) << "," << FormatFixed(rec.visual_dtheta, 6)
              << ",";
        } else {
          csv << (r.rejection ? r.rejection->reason : "") << ",,,";
        }
        csv << (true_theta && prev_true ? FormatFixed(WrapAngle(*true_theta - *prev_true), 6) : "")
            << "," << r.edge_points << "," << r.features << "," << r.tracked_pairs << ","
            << r.registration_inliers << "," << r.group_closed << ","
            << FormatFixed(r.shift_m.x(), 3) << "," << FormatFixed(r.shift_m.y(), 3) << ","
            << FormatFixed(r.heading_turn_rad, 6);
        if (r.accepted && k > 0) {
          const auto& T = poses[k - 1].T_world_base;
          csv << "," << FormatFixed(T.translation().x(), 4) << ","
              << FormatFixed(T.translation().y(), 4) << "," << FormatFixed(HeadingOf(T), 5);
        } else {
          csv << ",,,";
        }
        const auto ms_at = [i](const std::vector<double>& v) {
          return i < v.size() ? FormatFixed(v[i], 3) : std::string();
        };
        csv << "," << ms_at(main.key_frame_ms) << "," << ms_at(main.snapshot_ms) << "\n";
        if (true_theta) prev_true = true_theta;
      }
      WriteText(fs::path(out_dir) / "keyframes.csv", csv.str());
    }
    std::vector<Eigen::Vector2d> true_path;
    if (truth.has_pose) {
      for (const auto& f : p.key_frames) {
        const auto gt =
            epmap::dataset::InterpolatePlanar(p.data.gt_base_pose, p.data.frames[f.index].stamp_ns);
        if (gt) true_path.push_back(truth.T_start_gt * Eigen::Vector2d(gt->x, gt->y));
      }
    }
    // The true cameras of the key frames on the floor plan: what the maps could have seen.
    std::vector<epmap::mobile_mapping::PlanarView> true_cameras;
    if (truth.has_pose) {
      // Half the horizontal field of view of the rectified left camera (centred principal point).
      const double half_fov = std::atan(0.5 * p.camera.width / p.camera.fx);
      for (const auto& f : p.key_frames) {
        const auto cam =
            epmap::dataset::PoseAt(p.data.gt_camera_pose, p.data.frames[f.index].stamp_ns);
        if (!cam) continue;
        const Eigen::Vector3d pos = cam->translation();
        const Eigen::Vector3d axis = cam->linear().col(2);  // optical axis
        if (axis.head<2>().norm() < 1e-6) continue;         // looking straight down or up
        true_cameras.push_back({truth.T_start_gt * pos.head<2>(),
                                truth.T_start_gt.linear() * axis.head<2>().normalized(), half_fov});
      }
    }
    WriteText(fs::path(out_dir) / "pmap.svg", Svg(maps.perceptual(), truth, true_path));
    cv::imwrite((fs::path(out_dir) / "grid.png").string(), GridPicture(grid_export, truth, poses));
    if (!truth.walls.empty()) {
      cv::imwrite((fs::path(out_dir) / "grid_errors.png").string(),
                  epmap::mobile_mapping::GridErrorPicture(grid_export, truth.walls, 65, 4,
                                                          truth.furniture));
    }
    cv::imwrite((fs::path(out_dir) / "pmap.png").string(),
                PmapPicture(maps.perceptual(), truth, true_path));

    // Figures.
    std::ostringstream j;
    const auto& last = poses.back();
    const PoseErrors odo = FinalErrors(p, truth, last.T_world_base_odometry, last.stamp_ns);
    const PoseErrors cor = FinalErrors(p, truth, last.T_world_base, last.stamp_ns);
    const double heading_target = std::max(3.0, 0.2 * odo.heading_deg);
    j << "{\"command\":\"maps\",\"dataset\":\"" << dataset_path
      << "\",\"frames\":" << p.data.frames.size() << ",\"key_frames\":" << p.key_frames.size()
      << ",\"panning_stops\":" << (p.panning_stops ? "true" : "false")
      << ",\"true_depth\":" << (p.true_depth ? "true" : "false")
      << ",\"camera\":{\"width\":" << p.camera.width << ",\"height\":" << p.camera.height
      << ",\"fx\":" << FormatFixed(p.camera.fx, 3)
      << ",\"baseline_m\":" << FormatFixed(p.camera.baseline_m, 5)
      << ",\"rectified_input\":" << (p.rectifier ? "false" : "true") << "}";
    const auto& c = maps.counters;
    j << ",\"counters\":{\"key_frames\":" << c.key_frames << ",\"rejected\":" << c.rejected
      << ",\"stops\":" << c.groups << ",\"views\":" << c.views
      << ",\"views_without_objects\":" << c.views_without_objects << ",\"map_expansions\":"
      << std::count_if(maps.perceptual().views.begin(), maps.perceptual().views.end(),
                       [](const auto& v) { return v.in_map; })
      << ",\"visual_heading\":" << c.visual_heading
      << ",\"odometry_heading\":" << c.odometry_heading << ",\"registrations\":" << c.registrations
      << ",\"shifts_applied\":" << c.shifts_applied << ",\"shifts_refused\":" << c.shifts_refused
      << ",\"heading_turns\":" << c.heading_turns << ",\"rejected_by_reason\":{";
    bool first = true;
    for (const auto& [reason, n] : c.rejected_by_reason) {
      j << (first ? "" : ",") << "\"" << reason << "\":" << n;
      first = false;
    }
    j << "}}";
    j << ",\"heading\":{\"odometry_final_error_deg\":" << FormatFixed(odo.heading_deg, 3)
      << ",\"corrected_final_error_deg\":" << FormatFixed(cor.heading_deg, 3)
      << ",\"target_deg\":" << FormatFixed(heading_target, 3) << ",\"pass\":"
      << (std::isfinite(cor.heading_deg) ? (cor.heading_deg <= heading_target ? "true" : "false")
                                         : "null")
      << "},\"position\":{\"odometry_final_error_m\":" << FormatFixed(odo.position_m, 3)
      << ",\"corrected_final_error_m\":" << FormatFixed(cor.position_m, 3);
    {
      const auto odo_all = PositionErrors(p, truth, poses, true);
      const auto cor_all = PositionErrors(p, truth, poses, false);
      j << ",\"key_frames_scored\":" << cor_all.size()
        << ",\"odometry_median_error_m\":" << FormatFixed(Median(odo_all), 3)
        << ",\"corrected_median_error_m\":" << FormatFixed(Median(cor_all), 3)
        << ",\"corrected_p90_error_m\":" << FormatFixed(Percentile(cor_all, 0.9), 3) << "}";
    }
    {
      const ShiftCheck sc = CheckShifts(p, truth, main.reports, poses);
      j << ",\"correlation\":{\"enabled\":" << (params.map_correlation ? "true" : "false")
        << ",\"shifts_applied\":" << sc.applied;
      if (truth.has_pose && sc.applied > 0) {
        j << ",\"shifts_toward_truth\":" << sc.toward_truth
          << ",\"error_before_shift_m_median\":" << FormatFixed(Median(sc.error_before_m), 4)
          << ",\"error_after_shift_m_median\":" << FormatFixed(Median(sc.error_after_m), 4);
      }
      j << "}";
    }

    const auto segs = ToSegments(maps.perceptual().segments);
    const auto kept = ToSegments(maps.perceptual().kept_segments);
    j << ",\"perceptual_map\":{\"segments\":" << segs.size() << ",\"kept_segments\":" << kept.size()
      << ",\"segment_length_m\":" << FormatFixed(epmap::mobile_mapping::TotalLength(segs), 2);
    {
      // Views that joined the map, and how many of them no common object could anchor (placed
      // by the motion since the previous map view instead, III-C's fallback).
      size_t in_map = 0, by_motion = 0;
      for (const auto& v : maps.perceptual().views) {
        in_map += v.in_map;
        by_motion += v.in_map && v.placed_by_pose;
      }
      j << ",\"view_placement\":\""
        << (params.perceptual.place_by_pose ? "corrected pose" : "common objects (paper 003 III-C)")
        << "\",\"map_views\":" << in_map << ",\"map_views_placed_by_motion\":" << by_motion;
    }
    if (!truth.walls.empty()) {
      const double cov = epmap::mobile_mapping::CoveredShare(truth.walls, segs, 0.5);
      const auto visible =
          epmap::mobile_mapping::VisibleParts(truth.walls, true_path, params.edges.max_range_m);
      const double visible_len = epmap::mobile_mapping::TotalLength(visible);
      const double cov_vis = epmap::mobile_mapping::CoveredShare(visible, segs, 0.5);
      // The most a map of the walls in view can cover: both faces of a wall lie within the
      // tolerance of the face it sees.
      const double coverable = epmap::mobile_mapping::CoveredShare(truth.walls, visible, 0.5);
      // The same with the key frames' cameras and their field of view: what the map could
      // have seen at all, and the most it can cover.
      const auto seen = epmap::mobile_mapping::VisibleSeenParts(truth.walls, true_cameras,
                                                                params.edges.max_range_m);
      const double seen_len = epmap::mobile_mapping::TotalLength(seen);
      const double cov_seen =
          seen.empty() ? kNaN : epmap::mobile_mapping::CoveredShare(seen, segs, 0.5);
      const double seen_bound =
          seen.empty() ? kNaN : epmap::mobile_mapping::CoveredShare(truth.walls, seen, 0.5);
      const double stray = 1.0 - epmap::mobile_mapping::CoveredShare(segs, truth.walls, 1.0);
      const double cov_kept = epmap::mobile_mapping::CoveredShare(truth.walls, kept, 0.5);
      const double stray_kept = 1.0 - epmap::mobile_mapping::CoveredShare(kept, truth.walls, 1.0);
      const double wall_len = epmap::mobile_mapping::TotalLength(truth.walls);
      j << ",\"wall_length_m\":" << FormatFixed(wall_len, 2)
        << ",\"wall_coverage_0p5m\":" << FormatFixed(cov, 4) << ",\"wall_coverage_target\":0.70"
        << ",\"wall_coverage_upper_bound\":" << FormatFixed(coverable, 4)
        << ",\"visible_wall_share\":"
        << FormatFixed(wall_len > 0 ? visible_len / wall_len : kNaN, 4)
        << ",\"visible_wall_length_m\":" << FormatFixed(visible_len, 2)
        << ",\"visible_wall_coverage_0p5m\":" << FormatFixed(cov_vis, 4)
        << ",\"seen_wall_length_m\":" << FormatFixed(seen_len, 2)
        << ",\"seen_wall_coverage_0p5m\":" << FormatFixed(cov_seen, 4)
        << ",\"wall_coverage_seen_bound\":" << FormatFixed(seen_bound, 4)
        << ",\"stray_share_1m\":" << FormatFixed(stray, 4) << ",\"stray_target\":0.15"
        << ",\"kept_wall_coverage_0p5m\":" << FormatFixed(cov_kept, 4)
        << ",\"kept_stray_share_1m\":" << FormatFixed(stray_kept, 4);
      if (!truth.furniture.empty()) {
        auto solid = truth.walls;
        solid.insert(solid.end(), truth.furniture.begin(), truth.furniture.end());
        j << ",\"stray_share_1m_walls_and_furniture\":"
          << FormatFixed(1.0 - epmap::mobile_mapping::CoveredShare(segs, solid, 1.0), 4);
      }
    }
    if (!compare_path.empty()) {
      const OtherMap other = ReadPmap(compare_path);
      // Both maps into one frame: the ground truth's world when both know their start in it,
      // otherwise both are taken to start at the same pose (paper 003's protocol).
      std::vector<Segment2> a = segs, b = other.segments;
      const bool in_gt = truth.has_pose && other.T_gt_start.has_value();
      if (in_gt) {
        for (auto& s : a) s = {truth.T_gt_start * s.a, truth.T_gt_start * s.b};
        for (auto& s : b) s = {*other.T_gt_start * s.a, *other.T_gt_start * s.b};
      }
      const double ab = epmap::mobile_mapping::CoveredShare(a, b, 0.5);
      const double ba = epmap::mobile_mapping::CoveredShare(b, a, 0.5);
      j << ",\"compare\":{\"other\":\"" << compare_path << "\",\"frame\":\""
        << (in_gt ? "ground truth world" : "shared start pose")
        << "\",\"this_covered_by_other_0p5m\":" << FormatFixed(ab, 4)
        << ",\"other_covered_by_this_0p5m\":" << FormatFixed(ba, 4)
        << ",\"shape_similarity\":" << FormatFixed(0.5 * (ab + ba), 4) << "}";
    }
    j << "}";

    const auto grid_score_against = [&](const epmap::occupancy::GridExport& g,
                                        const std::vector<Segment2>& solid) {
      const auto s = epmap::mobile_mapping::ScoreGrid(g, solid);
      std::ostringstream o;
      o << "{\"iou\":" << FormatFixed(s.iou, 4)
        << ",\"iou_observed\":" << FormatFixed(s.iou_observed, 4)
        << ",\"occupied_cells\":" << s.occupied << ",\"wall_cells\":" << s.wall_cells
        << ",\"wall_cells_observed\":"
        << s.wall_cells_observed
        // Occupied needs evidence: the intersection is at most the wall cells observed, the
        // union at least all wall cells, so no grid that saw these cells scores more.
        << ",\"iou_upper_bound\":"
        << FormatFixed(
               s.wall_cells ? static_cast<double>(s.wall_cells_observed) / s.wall_cells : kNaN, 4)
        << ",\"precision\":" << FormatFixed(s.precision, 4)
        << ",\"recall_observed\":" << FormatFixed(s.recall_observed, 4)
        << ",\"false_beside_wall\":" << s.false_beside_wall
        << ",\"false_away_from_wall\":" << s.false_away_from_wall << "}";
      return o.str();
    };
    const auto grid_score = [&](const epmap::occupancy::GridExport& g) {
      return grid_score_against(g, truth.walls);
    };
    j << ",\"occupancy\":{\"resolution_m\":" << FormatFixed(grid_export.resolution_m, 3)
      << ",\"width\":" << grid_export.width << ",\"height\":" << grid_export.height
      << ",\"layers\":" << grid_export.layer_count;
    if (!truth.walls.empty()) {
      j << ",\"corrected\":" << grid_score(grid_export) << ",\"iou_target\":0.5";
      // The same at other occupied thresholds (grid.yaml's occupied_thresh is 0.65).
      j << ",\"iou_by_occupied_threshold\":{";
      for (const int t : {55, 65, 75, 85, 95}) {
        const auto s =
            epmap::mobile_mapping::ScoreGrid(grid_export, truth.walls, static_cast<uint8_t>(t));
        j << (t == 55 ? "" : ",") << "\"" << t << "\":" << FormatFixed(s.iou, 4);
      }
      j << "}";
      // The same with cells of less confidence (kappa) than these left unknown (the export's
      // default is 0.05), on the same extent.
      j << ",\"iou_by_unknown_below\":{";
      for (const double k : {0.05, 0.1, 0.2, 0.3, 0.5}) {
        const auto s = epmap::mobile_mapping::ScoreGrid(
            OnExtentOf(maps.grid.Export(std::nullopt, k), grid_export), truth.walls);
        j << (k == 0.05 ? "" : ",") << "\"" << FormatFixed(k, 2)
          << "\":{\"iou\":" << FormatFixed(s.iou, 4)
          << ",\"precision\":" << FormatFixed(s.precision, 4)
          << ",\"recall_observed\":" << FormatFixed(s.recall_observed, 4) << "}";
      }
      j << "}";
      // Each height band alone: walls span them all, furniture only the bands it reaches
      // (desks and chairs the lowest ones), so the bands show where the false cells come from.
      j << ",\"by_layer\":[";
      const auto& bounds = maps.grid.params().layer_bounds_m;
      for (int l = 0; l < maps.grid.layer_count(); ++l) {
        const auto layer = OnExtentOf(maps.grid.Export(l), grid_export);
        j << (l == 0 ? "" : ",") << "{\"from_m\":" << FormatFixed(bounds[l], 2)
          << ",\"to_m\":" << FormatFixed(bounds[l + 1], 2) << ",\"walls\":" << grid_score(layer)
          << "}";
      }
      j << "]";
    }
    if (!truth.furniture.empty()) {
      // The same against walls and the furniture footprints the dataset lists.
      auto solid = truth.walls;
      solid.insert(solid.end(), truth.furniture.begin(), truth.furniture.end());
      j << ",\"corrected_walls_and_furniture\":" << grid_score_against(grid_export, solid);
    }

    std::string variants_json;
    if (!no_variants) {
      struct Variant {
        const char* name;
        bool heading, correlation, other_placement;
      };
      // The perceptual map placed the other way: from common objects (paper 003) when this run
      // placed its views by the pose, and the reverse.
      const bool by_pose = params.perceptual.place_by_pose;
      const char* other_placement =
          by_pose ? "perceptual_map_placed_by_common_objects" : "perceptual_map_placed_by_pose";
      std::ostringstream v;
      for (const Variant var : {Variant{"no_heading_correction", false, true, false},
                                Variant{"odometry_only", false, false, false},
                                Variant{other_placement, true, true, true}}) {
        auto vp = params;
        vp.visual_heading = var.heading;
        vp.map_correlation = var.correlation;
        // Without heading correction means from neither the images nor the map.
        if (!var.heading) vp.correlation_heading_step_rad = 0;
        if (var.other_placement) vp.perceptual.place_by_pose = !by_pose;
        const RunResult r = Run(p, vp, false, masks);
        const auto& rl = r.maps->poses.back();
        const PoseErrors e = FinalErrors(p, truth, rl.T_world_base, rl.stamp_ns);
        const auto g = r.maps->grid.Export();
        if (!var.other_placement) {
          if (!truth.walls.empty()) j << ",\"" << var.name << "\":" << grid_score(g);
          cv::imwrite((fs::path(out_dir) / (std::string("grid_") + var.name + ".png")).string(),
                      GridPicture(g, truth, r.maps->poses));
        } else {
          cv::imwrite((fs::path(out_dir) / (std::string(var.name) + ".png")).string(),
                      PmapPicture(r.maps->perceptual(), truth, true_path));
        }
        v << (v.tellp() > 0 ? "," : "") << "{\"name\":\"" << var.name
          << "\",\"final_heading_error_deg\":" << FormatFixed(e.heading_deg, 3)
          << ",\"final_position_error_m\":" << FormatFixed(e.position_m, 3);
        if (!truth.walls.empty()) {
          v << ",\"wall_coverage_0p5m\":"
            << FormatFixed(epmap::mobile_mapping::CoveredShare(
                               truth.walls, ToSegments(r.maps->perceptual().segments), 0.5),
                           4)
            << ",\"stray_share_1m\":"
            << FormatFixed(1.0 - epmap::mobile_mapping::CoveredShare(
                                     ToSegments(r.maps->perceptual().segments), truth.walls, 1.0),
                           4);
        }
        v << "}";
      }
      variants_json = v.str();
    }
    j << "}";
    if (!variants_json.empty()) j << ",\"variants\":[" << variants_json << "]";

    const double med = Median(main.key_frame_ms);
    const double sg = Median(main.sgbm_ms);
    // The baseline of the snapshot: its perceptual map built with it, on the mapping thread (as
    // before the map was built on first read), key frame by key frame in this run.
    std::vector<double> built_with_map = main.snapshot_ms;
    for (size_t i = 0; i < built_with_map.size() && i < main.snapshot_read_ms.size(); ++i) {
      built_with_map[i] += main.snapshot_read_ms[i];
    }
    j << ",\"timing\":{\"per_key_frame_ms_median\":" << FormatFixed(med, 2)
      << ",\"per_key_frame_ms_p90\":" << FormatFixed(Percentile(main.key_frame_ms, 0.9), 2)
      << ",\"per_key_frame_ms_max\":" << FormatFixed(Percentile(main.key_frame_ms, 1.0), 2)
      << ",\"per_key_frame_ms_median_by_quarter\":" << MediansByQuarter(main.key_frame_ms)
      << ",\"snapshot_ms_median\":" << FormatFixed(Median(main.snapshot_ms), 2)
      << ",\"snapshot_ms_median_by_quarter\":" << MediansByQuarter(main.snapshot_ms)
      << ",\"snapshot_ms_p90\":" << FormatFixed(Percentile(main.snapshot_ms, 0.9), 2)
      << ",\"snapshot_first_read_ms_median\":" << FormatFixed(Median(main.snapshot_read_ms), 2)
      << ",\"snapshot_first_read_ms_median_by_quarter\":" << MediansByQuarter(main.snapshot_read_ms)
      << ",\"snapshot_first_read_ms_p90\":"
      << FormatFixed(Percentile(main.snapshot_read_ms, 0.9), 2)
      << ",\"snapshot_with_map_built_ms_median_by_quarter\":" << MediansByQuarter(built_with_map)
      << ",\"snapshot_with_map_built_ms_p90\":" << FormatFixed(Percentile(built_with_map, 0.9), 2)
      << ",\"snapshot_ratio_to_built_with_map\":"
      << FormatFixed(Median(main.snapshot_ms) / Median(built_with_map), 3)
      << ",\"committed_snapshot\":{\"key_frames\":" << main.committed_snapshot_ms.size()
      << ",\"ms_median\":" << FormatFixed(Median(main.committed_snapshot_ms), 2)
      << ",\"ms_p90\":" << FormatFixed(Percentile(main.committed_snapshot_ms, 0.9), 2)
      << ",\"baseline\":\"the same snapshot with the perceptual map recomputed and the grid's "
         "cells copied\""
      << ",\"baseline_ms_median\":" << FormatFixed(Median(main.recomputed_snapshot_ms), 2)
      << ",\"baseline_ms_p90\":" << FormatFixed(Percentile(main.recomputed_snapshot_ms, 0.9), 2)
      << ",\"ratio_to_baseline\":"
      << FormatFixed(Median(main.committed_snapshot_ms) / Median(main.recomputed_snapshot_ms), 3)
      << "}"
      << ",\"target_ms\":100,\"baseline\":\"full-frame SGBM (64 disparities, block 5) on the "
         "same key frames\",\"baseline_sgbm_ms_median\":"
      << FormatFixed(sg, 2) << ",\"ratio_to_baseline\":" << FormatFixed(med / sg, 3) << "}";
    j << ",\"grid_window\":" << GridWindowJson(maps, 8.0, 20);
    j << ",\"pmap_window\":" << PmapWindowJson(maps, 8.0, 20);
    j << ",\"durable_state\":{\"bytes\":" << main.state_bytes
      << ",\"save_ms_median\":" << FormatFixed(Median(main.save_ms), 2)
      << ",\"restore_ms_median\":" << FormatFixed(Median(main.restore_ms), 2)
      << ",\"baseline\":\"per key frame ms median\",\"save_ratio_to_baseline\":"
      << FormatFixed(Median(main.save_ms) / med, 3)
      << ",\"round_trip_exact\":" << (main.state_round_trip_exact ? "true" : "false") << "}";
    // The EP ran on every frame before the maps (as in epmapd); its time is not per key frame.
    j << ",\"motion_mask\":{\"enabled\":" << (no_motion_mask ? "false" : "true")
      << ",\"ep_frames\":" << masks.frames << ",\"key_frames_masked\":" << masks.by_frame.size()
      << ",\"ep_ms_median\":" << FormatFixed(Median(masks.ep_ms), 2) << "}";
    j << ",\"outputs\":\"" << out_dir << "\"}";
    if (json) {
      std::cout << j.str() << "\n";
    } else {
      std::cout << "maps: " << p.key_frames.size() << " key frames -> " << out_dir << "\n"
                << j.str() << "\n";
    }
    WriteText(fs::path(out_dir) / "figures.json", j.str() + "\n");
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "epmap-bench maps: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

EPMAP_BENCH_COMMAND(maps, "maps",
                    "perceptual map + occupancy grid + corrected pose over a mobile-base dataset",
                    RunCommand);
