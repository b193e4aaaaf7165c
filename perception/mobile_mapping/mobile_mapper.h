#pragma once
// The two maps of a mobile base with a panning stereo head, fed one key frame at a time: the
// perceptual map of paper 003 and the fuzzy layered occupancy grid of paper 002, over the pose
// that paper 002's visual heading and map correlation correct. This is the code the service
// runs on its pipeline thread (no threads, clocks or I/O here); readers take immutable
// snapshots.
//
// Key frames at one base pose (a panning stop: the head turns, the base stays) form a group.
// When the base moves on, the group is closed: its points make a local occupancy map,
// registered to the global one by correlation over x and y and merged (paper 002, Sec. 2 and
// 4), and a view of the perceptual map (paper 003, Sec. III).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "perception/localisation/lorentzian_registration.h"
#include "perception/localisation/pose_corrector.h"
#include "perception/localisation/stereo_features.h"
#include "perception/occupancy/layered_grid.h"
#include "perception/perceptual_map/edge_stereo.h"
#include "perception/perceptual_map/perceptual_mapper.h"
#include "perception/stereo/rectification.h"

namespace epmap::mobile_mapping {

struct JointLimit {
  std::string name;
  double lower = 0, upper = 0;  // rad (m for prismatic joints)
};

// One key frame as the pipeline hands it over.
struct KeyFrame {
  int64_t stamp_ns = 0;
  cv::Mat left, right;  // rectified pair (the rig of MobileMapper's camera), grey or BGR
  // Wheel odometry: the base in the odometry frame, which is the robot's start pose.
  Eigen::Isometry2d T_odom_base = Eigen::Isometry2d::Identity();
  // The rectified left camera on the base, from the kinematic chain at this frame's joints.
  Eigen::Isometry3d T_base_cam = Eigen::Isometry3d::Identity();
  // Joint readings in the order of MobileMapperParams::joint_limits (may be empty).
  std::vector<double> joint_positions;
  // Optional, CV_8U of the left image's size: non-zero where something moves on its own (in
  // epmapd, the EP's unexpected mask of this frame, grown a little). No map point and no heading
  // feature is taken there: a person walking by is neither a wall nor a landmark to steer by.
  cv::Mat moving;
  // Evaluation only (epmap-bench maps --true-depth): CV_32FC1 of the left image's size, the
  // true disparity. When set, each map point (grid and perceptual map) takes its depth from it
  // where it is unambiguous (TrueDepthOf), so a benchmark can tell what the stereo's depth
  // error costs the maps from what the rest does. The heading still uses the stereo depths.
  cv::Mat true_disparity;
};

// The point of a rectified pixel at its true disparity, or nothing where the disparity is
// unknown (<= 0, not finite) or ambiguous: a sub-pixel point within kTrueDepthEdgePx of a
// depth edge (the true disparity varying by more than kTrueDepthEdgeSpreadPx there) may lie on
// either side of it.
inline constexpr int kTrueDepthEdgePx = 3;
inline constexpr float kTrueDepthEdgeSpreadPx = 0.5F;
std::optional<Eigen::Vector3d> TrueDepthOf(const cv::Mat& true_disparity,
                                           const stereo::RectifiedGeometry& camera, float u,
                                           float v);

// A motion mask (e.g. the EP's unexpected mask) grown by kMovingMaskGrowPx on each side, so
// that the edge points and corners along a moving thing's outline are left out too.
inline constexpr int kMovingMaskGrowPx = 3;
cv::Mat GrowMovingMask(const cv::Mat& mask);

struct MobileMapperParams {
  MobileMapperParams() {
    // The yaw alone (one unknown) is well determined by a handful of pairs.
    registration.vertical_axis_only = true;
    registration.min_pairs = 4;
    // The mapper owns a pose corrected by paper 002 (heading from the images, position from
    // the correlation): a view's new objects are placed by it rather than triangulated from
    // the nearest common object (paper 003 Sec. III-C, whose robot had only odometry). A
    // misplaced anchor moved a whole view, and every view after it, so the map's figures
    // swung from run to run; placed by the pose, on the rooms route: wall coverage 74.2 ->
    // 77.3 %, stray length 15.4 -> 12.9 % (mean of 4 runs,
    // perception/mobile_mapping/EXPERIMENTS.md).
    perceptual.place_by_pose = true;
    // A point also marks the body of the wall behind it: seen from a room and from the
    // corridor, the two faces of a 12 cm wall then fill the same cells, and the correlation no
    // longer pulls one face onto the other (same README).
    measurement.occupied_depth_m = 0.1;
  }

  perceptual_map::EdgeStereoParams edges;
  perceptual_map::PerceptualMapParams perceptual;
  occupancy::GridParams grid;
  occupancy::MeasurementParams measurement;
  localisation::StereoFeatureParams features;
  localisation::LorentzianParams registration;
  localisation::PoseCorrectorParams pose;

  double floor_z_in_base_m = 0.0;  // height of the floor in the base frame (REP 105: 0)
  // Reference points of the perceptual map: edge points between these heights above the floor
  // (floor texture and ceiling fixtures are not surfaces a 2-D map should hold; 6 cm keeps the
  // top of skirting boards, the floor's own texture stays below it within the depth noise).
  double reference_min_height_m = 0.06;
  double reference_max_height_m = 2.0;
  // ... except those in this band: the height of desks, seats, chair backs and monitors
  // (0.45-1.2 m in offices). Reference objects are what the robot tracks from view to view and
  // what bounds its space (paper 003 assumes a world "relatively stable"): walls, not the chairs
  // in front of them. The occupancy grid keeps every height for planners. Walls still show at
  // their base (skirting) and above the band. Four building runs: map length > 1 m from any
  // wall 17.5% -> 8.3% (mean), wall coverage 49.5% -> 48.6% (mobile_mapping README).
  // from >= to disables the band.
  double reference_skip_from_height_m = 0.3;
  double reference_skip_to_height_m = 1.2;
  // Edge points fed to the occupancy grid: one row in this many along each vertical edge. They
  // stand for the paper's line features cut into parts of a fixed image-plane length.
  int occupancy_edge_row_step = 4;
  // ... and only edges this close to vertical (|dI/dy| <= slope |dI/dx|): a slanted edge's
  // disparity is less precise, which a 10 cm grid shows where a line map does not.
  double occupancy_edge_max_slope = 1.0;
  // The corner features tracked for the heading go to the grid as points too. They are most of
  // its wall evidence: without them, rooms route grid IoU 0.390 -> 0.102 (README).
  bool occupancy_feature_points = true;

  bool visual_heading = true;  // paper 002, Sec. 3.3; off: the odometry's heading is kept
  // Fit only the rotation of a key-frame step, its translation taken from the odometry
  // (RegisterLorentzianRotation; registration.vertical_axis_only then fits the yaw alone). Off:
  // the paper's full rototranslation. See lorentzian_registration.h for why.
  bool step_translation_from_odometry = true;
  // A head that turned less than this between two key frames is taken as still (joint encoder
  // noise of ~0.02 degrees would otherwise add to every visual heading step while driving).
  double head_still_rad = 0.002;
  bool map_correlation = true;  // paper 002, Sec. 4: translation by local/global correlation
  double correlation_search_m = 0.5;
  // A correlation shift is applied only when its peak beats the unshifted score by this share
  // (a flat correlation, e.g. along a corridor, must not move the robot).
  double correlation_min_gain = 0.05;
  size_t correlation_min_cells = 30;  // local maps with less structure are merged unshifted
  // The sub-cell part of the shift (parabola through the peak) is applied along an axis whose
  // peak is at least this sharp (see occupancy::Registration): odometry drifts by centimetres
  // between stops, less than a cell, and whole-cell shifts alone would never catch it.
  double correlation_min_sharpness = 0.05;
  double correlation_min_shift_m = 0.005;  // smaller corrections are noise
  // A larger correction at one stop is refused: odometry does not drift that much between two
  // stops, so such a peak is an alias (a repeated structure, a wall seen from its far end).
  // Applied shifts on the building runs: median 2 cm, p90 4-6 cm; 0.25 m let one alias through.
  double correlation_max_shift_m = 0.15;
  // A correlation shift is a measurement of the position error, not the error itself. A 1-D
  // Kalman filter per world axis weighs it against how far odometry can have drifted since
  // the last correction (variance grows by (drift_per_m * metres driven)^2 from stop to stop)
  // and applies gain = P / (P + sigma^2) of it. Taking every shift whole (the paper; drift 0
  // here) makes the position wander by centimetres from stop to stop, each shift's noise
  // added to all later poses. Rooms route, mean of 4 runs of the median position error over
  // the key frames: 8.4 cm whole, 3.7 cm filtered (with the occupied depth above); with
  // odometry that under-counts the distance by 1 %, 10.4 cm whole, 8.7 cm filtered, 12.8 cm
  // without any correlation (perception/mobile_mapping/EXPERIMENTS.md). Set it to the base's own
  // drift; 0.02 is a wheeled base's usual 1-5 %'s lower end.
  // Noise of one shift, in cells: the parabola through the peak places it to about a third of
  // a cell (3 cm on the default 0.1 m lattice), so it scales with grid.resolution_m.
  double correlation_sigma_cells = 0.3;
  double odometry_drift_per_m = 0.02;  // 0: every shift taken whole (paper 002)
  // Beyond paper 002, which correlates over x and y only and takes the heading from vision:
  // the visual heading is integrated key frame by key frame, so it drifts without bound (rooms
  // route, 0.2 deg after one pass, 1.3 after four, 3 after twelve), and a local map turned by
  // the error correlates with the global one a cell off at its far walls: a long run's grid
  // smears. Each registration also scores the local map turned by -step and +step about the
  // stop; the parabola through the three peak scores measures the heading error (noise
  // correlation_heading_sigma_rad), weighed by a Kalman filter against how far the heading can
  // have drifted since the last stop (heading_drift_rad_per_m * metres driven +
  // heading_drift_per_rad * the angle turned: the visual heading errs most in turns, about
  // 0.2 deg per turn into a room), and that share turns the stop's poses and all later ones.
  // 0: off (paper 002). Rooms route driven twelve times (750 m): final heading error 3.5 ->
  // 0.4 deg, grid IoU 0.16 -> 0.30; one pass within its noise (EXPERIMENTS.md, 36th session).
  double correlation_heading_step_rad = 0.5 * std::numbers::pi / 180.0;
  double correlation_heading_sigma_rad = 0.005;  // 0.3 deg
  double heading_drift_rad_per_m = 0.0002;       // 0.01 deg per metre
  double heading_drift_per_rad = 0.003;          // 0.3 % of the angle turned

  // Groups of fewer key frames are not views (2+: only panning stops make views; 1: every
  // key frame where the base stands is a view, for a robot that never stops to pan; 0:
  // automatic, 1 until the head has been seen panning while the base stood still, 2 from then
  // on, which is what the service uses: it cannot know the robot's habits in advance).
  int view_min_key_frames = 1;

  // Input checks between consecutive accepted key frames.
  double max_odometry_step_m = 2.0;  // a larger jump is refused as a glitch
  double max_odometry_step_rad = 1.6;
  double max_odometry_speed_mps = 3.0;
  std::vector<JointLimit> joint_limits;  // empty: not checked

  void Validate() const;
};

// Why a key frame was refused (also the counter's name).
struct Rejection {
  std::string reason;   // short name, e.g. "stamp_not_increasing"
  std::string message;  // what a person can act on
};

struct KeyFrameReport {
  bool accepted = false;
  std::optional<Rejection> rejection;
  localisation::HeadingSource heading_source = localisation::HeadingSource::kStart;
  size_t edge_points = 0;
  size_t reference_points = 0;  // edge points kept for the perceptual map (by height)
  size_t features = 0;
  size_t tracked_pairs = 0;
  int registration_inliers = 0;
  bool group_closed = false;  // this key frame closed the previous stop
  bool view_skipped = false;  // that stop had no reference object
  bool map_expanded = false;  // the perceptual map grew
  bool shifted = false;       // correlation moved the pose
  Eigen::Vector2d shift_m = Eigen::Vector2d::Zero();
  // The registration turned the heading by this (correlation_heading_step_rad).
  double heading_turn_rad = 0;
  // Set when this was the first key frame after RestoreState and it did not continue the
  // saved run (why): the restored maps were dropped and this key frame started new ones.
  std::optional<std::string> restored_maps_dropped;
};

struct MapperCounters {
  uint64_t key_frames = 0;  // accepted
  uint64_t rejected = 0;
  std::map<std::string, uint64_t> rejected_by_reason;
  uint64_t groups = 0;  // stops closed
  uint64_t groups_too_short = 0;
  uint64_t views = 0;  // groups that made a perceptual-map view
  uint64_t views_without_objects = 0;
  uint64_t visual_heading = 0;    // key frames whose heading change came from vision
  uint64_t odometry_heading = 0;  // moved, but the visual estimate failed or was refused
  uint64_t registrations = 0;     // local maps correlated with the global one
  uint64_t shifts_applied = 0;
  uint64_t shifts_refused = 0;  // peak on the search border or implausibly far
  uint64_t heading_turns = 0;   // stops whose heading the registration turned
};

// A snapshot's perceptual map, built when first read. Its redundancy removal and boundary
// (paper 003, Sec. III-D) cost time that grows with the map and the path (tens of ms after a
// few hundred metres of a floor driven again), while readers poll slower than key frames come:
// the mapper hands out a copy of its perceptual mapper and the first reader pays for the map,
// on the reader's thread. Thread-safe: concurrent first readers wait for one computation.
class PerceptualMapOnRead {
 public:
  // Told how long the build took (ms), on the thread of the reader that built the map; it may
  // run after the mapper is gone, so it must own what it uses.
  using OnBuilt = std::function<void(double ms)>;
  // PerceptualMapper::Map(true) of `mapper`, when first read.
  explicit PerceptualMapOnRead(perceptual_map::PerceptualMapper mapper, OnBuilt on_built = {});
  const perceptual_map::PerceptualMap& Get() const;

 private:
  mutable std::once_flag built_;
  mutable std::optional<perceptual_map::PerceptualMapper> mapper_;  // until built
  mutable perceptual_map::PerceptualMap map_;
  OnBuilt on_built_;
};

// What readers get: immutable once built.
struct MapsSnapshot {
  int64_t stamp_ns = 0;
  bool includes_open_stop = false;  // the stop under way is merged provisionally
  // Restored from saved state (a restart of the service) and not yet confirmed or dropped by
  // a key frame: the maps as they were saved, in an odometry frame not yet checked to continue.
  bool resumed_unconfirmed = false;
  // The perceptual map (built on first read, see PerceptualMapOnRead; an empty map if unset).
  const perceptual_map::PerceptualMap& perceptual() const;
  std::shared_ptr<const PerceptualMapOnRead> perceptual_on_read;
  occupancy::LayeredGrid grid;
  std::vector<localisation::PoseRecord> poses;  // one per accepted key frame
  MapperCounters counters;
};

class MobileMapper {
 public:
  // camera: the rectified rig the key frames come from. Throws std::invalid_argument on bad
  // parameters or camera.
  MobileMapper(const stereo::RectifiedGeometry& camera, const MobileMapperParams& params = {});

  // Processes one key frame. Bad input (stamps not increasing, odometry jumping or not
  // finite, images missing or of another size, a joint outside its limits) is refused with a
  // reason and counted; the maps are left as they were. Never throws for bad input.
  KeyFrameReport AddKeyFrame(const KeyFrame& frame);

  // Closes the open stop (end of a run): its local map and view join the maps.
  void Flush();

  // An immutable copy of everything a reader may want.
  std::shared_ptr<const MapsSnapshot> Snapshot() const;
  // The same, with the open stop merged as if it closed now (on copies: the maps themselves
  // wait until the base moves on, when the stop is complete). A stop joins the maps only when
  // it ends; a planner asking while the robot stands and looks around wants what it sees now.
  // Without a standing stop (below), the same as Snapshot(). Costs a copy of the maps and one
  // registration.
  std::shared_ptr<const MapsSnapshot> SnapshotWithOpenStop() const;
  // Called whenever a reader builds a snapshot's perceptual map (PerceptualMapOnRead::OnBuilt):
  // how a service still sees what the readers pay for the maps (epmapd: maps.perceptual_read).
  void SetOnPerceptualMapBuilt(PerceptualMapOnRead::OnBuilt on_built) {
    on_perceptual_map_built_ = std::move(on_built);
  }
  // The base stands at an open stop (two key frames or more there) that would make a view if
  // it closed now. (A moving base opens a one-key-frame group at each key frame; the next one
  // closes it.)
  bool standing_at_stop() const;

  // The maps, the poses, the counters and the correlation's filter as bytes (a versioned
  // binary format, mapper_state.cc), for a service that must resume its maps after a restart.
  // The open stop is not in them: its key frames' points are not kept, so a stop under way is
  // lost on a restart; every closed stop is there.
  std::string SaveState() const;
  // On a mapper that has accepted no key frame: takes over saved maps. Returns false with a
  // reason, changing nothing, for bytes that are not a whole state of this format, or a state
  // of another camera or grid lattice (resolution, height bands). The first key frame after it
  // must continue the saved run: a later stamp, odometry within the jump limits of the saved
  // last pose. Otherwise the odometry is not the frame the maps are in (the base restarted its
  // odometry, or the robot was carried): the restored maps are dropped and that key frame
  // starts new ones (KeyFrameReport::restored_maps_dropped).
  bool RestoreState(std::string_view bytes, std::string* reason);
  // RestoreState took a state and no key frame has confirmed or dropped it yet.
  bool restore_unconfirmed() const { return restore_unconfirmed_; }
  // The camera saved maps were made with (a mapper for them needs it before any frame), or
  // nullopt with a reason for bytes that do not start as a state of this format.
  static std::optional<stereo::RectifiedGeometry> SavedCamera(std::string_view bytes,
                                                              std::string* reason);

  const MapperCounters& counters() const { return counters_; }
  const localisation::PoseCorrector& poses() const { return poses_; }
  const occupancy::LayeredGrid& grid() const { return grid_; }
  const perceptual_map::PerceptualMapper& perceptual() const { return perceptual_; }
  const MobileMapperParams& params() const { return params_; }
  const stereo::RectifiedGeometry& camera() const { return camera_; }

 private:
  struct FramePoints {
    Eigen::Vector3d camera_in_base;
    std::vector<Eigen::Vector3d> points_base;  // occupancy points (base frame)
    std::vector<double> sigmas;
    std::vector<Eigen::Vector2d> reference_points;  // perceptual-map points (base plane)
  };
  struct Group {
    bool open = false;
    Eigen::Isometry2d T_odom_base = Eigen::Isometry2d::Identity();
    size_t first_record = 0;
    std::vector<FramePoints> frames;
  };

  // The correlation's Kalman filter (MobileMapperParams::correlation_sigma_cells): variance of
  // the position error along world x and y, and where the last stop stood.
  struct PositionFilter {
    Eigen::Vector2d variance = Eigen::Vector2d::Zero();
    std::optional<Eigen::Vector2d> last_stop;
    double heading_variance = 0;  // of the heading error (correlation_heading_step_rad)
    double last_stop_heading = 0;
  };
  // What closing a stop changes: the maps, the poses (registration) and the counters.
  struct MapsState {
    occupancy::LayeredGrid& grid;
    perceptual_map::PerceptualMapper& perceptual;
    localisation::PoseCorrector& poses;
    MapperCounters& counters;
    PositionFilter& filter;
  };

  std::optional<Rejection> Check(const KeyFrame& frame) const;
  int MinKeyFramesForView() const;
  void CloseGroup(KeyFrameReport* report);
  // Registers the group's local map, merges it and adds its view (paper 002 Sec. 4, paper 003
  // Sec. III-C) into `state`.
  void MergeGroup(const Group& group, MapsState state, KeyFrameReport* report) const;

  stereo::RectifiedGeometry camera_;
  MobileMapperParams params_;
  localisation::StereoFeatureTracker tracker_;
  localisation::PoseCorrector poses_;
  perceptual_map::PerceptualMapper perceptual_;
  occupancy::LayeredGrid grid_;
  std::optional<localisation::KeyFrameFeatures> previous_features_;
  bool seen_panning_stop_ = false;  // for view_min_key_frames = 0
  Group group_;
  PositionFilter filter_;
  MapperCounters counters_;
  int64_t last_stamp_ns_ = 0;
  cv::Size image_size_;
  bool restore_unconfirmed_ = false;
  // The perceptual map the last Snapshot() handed out, kept while perceptual_.revision() says
  // it still holds: while the base drives between stops no view joins, and every snapshot of
  // one revision shares one map, built once when first read. Single-threaded like the rest.
  mutable std::shared_ptr<const PerceptualMapOnRead> published_perceptual_;
  mutable uint64_t published_perceptual_revision_ = 0;
  PerceptualMapOnRead::OnBuilt on_perceptual_map_built_;  // handed to every snapshot's map
  // Back to a mapper that has seen nothing (the restored maps were not the odometry's).
  void ClearMaps();
};

}  // namespace epmap::mobile_mapping
