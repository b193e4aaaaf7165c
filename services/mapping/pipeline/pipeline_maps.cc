// The pipeline's maps stage (mobile-base mode; issue 6, perception/mobile_mapping): each frame's
// rectified pair, the rt/odom pose interpolated to its stamp and the head's joints (the pan)
// from rt/joint_states go to the same MobileMapper `epmap-bench maps` runs; key frames update
// the perceptual map, the occupancy grid and the corrected pose, which the snapshot carries to
// GetPerceptualMap, GetOccupancyGrid and GetPose.

#include <spdlog/spdlog.h>

#include <cmath>
#include <numbers>

#include "services/mapping/pipeline/pipeline.h"
#include "services/mapping/pipeline/rectified_camera.h"

namespace epmap::mapping {

namespace {

using Clock = std::chrono::steady_clock;

mobile_mapping::MobileMapperParams MakeMapperParams(
    const MapsSettings& s, const std::vector<mobile_mapping::JointLimit>& limits) {
  mobile_mapping::MobileMapperParams p;
  p.visual_heading = s.visual_heading;
  p.map_correlation = s.map_correlation;
  p.odometry_drift_per_m = s.odometry_drift_per_m;
  p.correlation_heading_step_rad = s.heading_registration_step_deg * std::numbers::pi / 180.0;
  p.grid.resolution_m = s.grid_resolution_m;
  p.perceptual.place_by_pose = s.place_views_by_pose;
  p.view_min_key_frames = s.view_min_key_frames;
  p.max_odometry_step_m = s.max_odometry_step_m;
  p.max_odometry_step_rad = s.max_odometry_step_rad;
  p.max_odometry_speed_mps = s.max_odometry_speed_mps;
  p.reference_skip_from_height_m = s.reference_skip_from_height_m;
  p.reference_skip_to_height_m = s.reference_skip_to_height_m;
  p.joint_limits = limits;
  return p;
}

// The mapper epmapd runs. A snapshot's perceptual map is built by its first reader (a gRPC
// call, the ROS publisher), on that reader's thread: the time goes to the stage timings as
// maps.perceptual_read.
std::unique_ptr<mobile_mapping::MobileMapper> MakeMapper(
    const stereo::RectifiedGeometry& camera, const MapsSettings& settings,
    const std::vector<mobile_mapping::JointLimit>& limits, std::shared_ptr<RollingStats> stages) {
  auto mapper =
      std::make_unique<mobile_mapping::MobileMapper>(camera, MakeMapperParams(settings, limits));
  mapper->SetOnPerceptualMapBuilt(
      [stages = std::move(stages)](double ms) { stages->Add("maps.perceptual_read", ms); });
  return mapper;
}

uint64_t MergedStops(const mobile_mapping::MapperCounters& c) {
  return c.views + c.views_without_objects;
}

}  // namespace

void Pipeline::OpenMapsStore() {
  if (!config_.maps.enabled || !config_.maps.persist || config_.state_dir.empty()) return;
  // A head or a fixed rig builds no maps: a store there would resume maps nothing updates.
  if (config_.mode != "auto" && config_.mode != "mobile-base") return;
  try {
    maps_store_ = std::make_unique<MapsStore>(config_.state_dir, events_);
  } catch (const std::exception& e) {
    // The maps still work, in memory only.
    events_.Increment("maps_store_unavailable");
    spdlog::error("maps: no durable maps: {}", e.what());
  }
}

bool Pipeline::RequestMapsReset() {
  std::lock_guard lock(maps_reset_mutex_);
  maps_reset_requested_ = true;
  ForgetResumedMaps();
  if (!maps_store_) return false;
  maps_store_->Clear();
  return true;
}

void Pipeline::ApplyMapsReset() {
  {
    std::lock_guard lock(maps_reset_mutex_);
    if (!maps_reset_requested_) return;
    maps_reset_requested_ = false;
  }
  mapper_.reset();
  key_frames_.reset();
  maps_.reset();
  maps_saved_stops_ = 0;
  events_.Increment("maps_reset");
  spdlog::info("maps: reset on request; the next key frames start new maps");
}

void Pipeline::ResumeSavedMaps() {
  if (!maps_store_) return;
  try {
    const auto saved = maps_store_->Load();
    if (!saved) return;
    // The mapper is made for the camera the maps were saved with; a first frame from another
    // camera drops them (RunMaps).
    std::string reason;
    const auto camera = mobile_mapping::MobileMapper::SavedCamera(saved->bytes, &reason);
    auto mapper = camera ? MakeMapper(*camera, config_.maps, joint_limits_, stage_ms_) : nullptr;
    if (!mapper || !mapper->RestoreState(saved->bytes, &reason)) {
      events_.Increment("maps_saved_not_resumed");
      spdlog::warn("maps: the saved maps in {} are not resumed, new maps start: {}",
                   maps_store_->path().string(), reason);
      return;
    }
    mapper_ = std::move(mapper);
    maps_saved_stops_ = MergedStops(mapper_->counters());
    maps_ = mapper_->Snapshot();
    {
      std::lock_guard lock(resumed_maps_mutex_);
      resumed_maps_ = maps_;
    }
    events_.Increment("maps_resumed");
    spdlog::info(
        "maps: resuming the saved maps of {} ({} key frames, {} views taken, {} segments joined "
        "before the newest view's), served from now on; the first key frame decides whether the "
        "odometry continues them",
        maps_store_->path().string(), saved->key_frames, mapper_->counters().views,
        mapper_->perceptual().segments());
  } catch (const std::exception& e) {
    events_.Increment("maps_saved_not_resumed");
    spdlog::error("maps: the saved maps cannot be read, new maps start: {}", e.what());
  }
}

std::shared_ptr<const mobile_mapping::MapsSnapshot> Pipeline::ResumedMapsBeforeFirstFrame() const {
  std::lock_guard lock(resumed_maps_mutex_);
  return resumed_maps_;
}

void Pipeline::ForgetResumedMaps() {
  std::lock_guard lock(resumed_maps_mutex_);
  resumed_maps_.reset();
}

void Pipeline::SaveMaps(bool now_regardless) {
  if (!maps_store_ || !mapper_ || mapper_->restore_unconfirmed()) return;
  const uint64_t merged = MergedStops(mapper_->counters());
  if (merged == maps_saved_stops_) return;  // nothing new since the last save
  const auto now = Clock::now();
  if (!now_regardless &&
      now - maps_saved_at_ < std::chrono::duration<double>(config_.maps.save_period_s)) {
    return;
  }
  std::lock_guard lock(maps_reset_mutex_);
  if (maps_reset_requested_) return;  // these maps are about to go: never save them again
  const auto t0 = Clock::now();
  maps_store_->Offer(mapper_->SaveState(), mapper_->counters().key_frames);
  stage_ms_->Add("maps.save_state",
                 std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  maps_saved_stops_ = merged;
  maps_saved_at_ = now;
}

void Pipeline::RunMaps(const StereoFrame& frame, const stereo::Rectifier& rectifier,
                       const cv::Mat& left, const cv::Mat& right, MapSnapshot& snapshot) {
  ApplyMapsReset();
  snapshot.maps = maps_;  // unchanged until a key frame is accepted
  if (!chain_) {
    // Without the chain from the base to the camera the points cannot be placed on the floor.
    counters_.key_frames_refused.Increment("maps:no_urdf");
    return;
  }
  const auto wait = std::chrono::nanoseconds(config_.joints_wait_ns);
  std::string reason;
  std::vector<double> joints;
  if (!chain_->joint_names().empty()) {
    auto q = sensors_.JointsAt(frame.stamp_ns, chain_->joint_names(), config_.joints_max_gap_ns,
                               wait, &reason);
    if (!q) {
      counters_.key_frames_refused.Increment("maps:no_joints");
      return;
    }
    joints = std::move(*q);
  }
  const auto odom = sensors_.OdometryAt(frame.stamp_ns, config_.joints_max_gap_ns, wait, &reason);
  if (!odom) {
    counters_.key_frames_refused.Increment("maps:no_odometry");
    return;
  }
  WarnOnceIfTheOdometryIsNotInTheConfiguredFrames();

  mobile_mapping::KeyFrame key_frame;
  key_frame.stamp_ns = frame.stamp_ns;
  key_frame.left = left;
  key_frame.right = right;
  {
    const Eigen::Isometry3d T = UrdfRootOnOdometry(*odom, joints);
    key_frame.T_odom_base = Eigen::Translation2d(T.translation().x(), T.translation().y()) *
                            Eigen::Rotation2Dd(std::atan2(T.linear()(1, 0), T.linear()(0, 0)));
  }
  key_frame.T_base_cam = chain_->Cam0Pose(joints) * RawToRectified(rectifier);
  key_frame.joint_positions = joints;
  // What the EP found moving on its own in this very frame stays out of the maps, grown by a
  // few pixels (the mask is on the comparison grid's resolution at its edges).
  if (snapshot.ep && snapshot.ep->stamp_ns == frame.stamp_ns && snapshot.ep->unexpected_share > 0 &&
      snapshot.ep->unexpected.size() == left.size()) {
    key_frame.moving = mobile_mapping::GrowMovingMask(snapshot.ep->unexpected);
  }
  if (!std::isfinite(odom->x) || !std::isfinite(odom->y) || !std::isfinite(odom->theta)) {
    counters_.key_frames_refused.Increment("maps:odometry_not_finite");
    return;
  }

  if (!key_frames_) {
    mobile_mapping::KeyFrameSelectorParams kp;
    kp.min_translation_m = config_.maps.key_frame_min_translation_m;
    kp.min_rotation_rad = config_.maps.key_frame_min_rotation_rad;
    kp.min_camera_rotation_rad = config_.maps.key_frame_min_pan_rad;
    key_frames_.emplace(kp);
  }
  if (!key_frames_->Consider(key_frame.T_odom_base, key_frame.T_base_cam)) return;

  if (!mapper_ || !SameGeometry(mapper_->camera(), rectifier.geometry())) {
    // A new rectification (another camera, a new stereo model) makes the old maps' points
    // incomparable with the new ones: the maps restart, counted.
    if (mapper_ && mapper_->restore_unconfirmed()) {
      events_.Increment("maps_saved_not_resumed");
      spdlog::warn(
          "maps: the saved maps were made with another camera than this one ({}x{}, "
          "fx {}, baseline {} m); new maps start",
          rectifier.geometry().width, rectifier.geometry().height, rectifier.geometry().fx,
          rectifier.geometry().baseline_m);
    } else if (mapper_) {
      events_.Increment("maps_restarted_new_rectification");
    }
    ForgetResumedMaps();
    mapper_ = MakeMapper(rectifier.geometry(), config_.maps, joint_limits_, stage_ms_);
    maps_.reset();
    snapshot.maps.reset();
    maps_saved_stops_ = 0;
  }

  const auto t0 = Clock::now();
  mobile_mapping::KeyFrameReport report;
  try {
    report = mapper_->AddKeyFrame(key_frame);
  } catch (const std::exception& e) {
    // An algorithm failure on one key frame must not end the maps: counted, frame skipped.
    counters_.key_frames_refused.Increment("maps:exception");
    spdlog::warn("maps: key frame {} failed: {}", frame.stamp_ns, e.what());
    return;
  }
  if (!report.accepted) {
    const auto& r = report.rejection;
    counters_.key_frames_refused.Increment("maps:" + (r ? r->reason : std::string("refused")));
    spdlog::warn("maps: key frame {} refused: {}", frame.stamp_ns,
                 r ? r->message : std::string("no reason given"));
    return;
  }
  ForgetResumedMaps();  // from here on every snapshot carries the maps
  if (report.restored_maps_dropped) {
    events_.Increment("maps_resume_dropped");
    spdlog::warn("maps: the saved maps are not this odometry's, new maps start: {}",
                 *report.restored_maps_dropped);
    maps_saved_stops_ = 0;
  }
  key_frame_awaits_publish_ = true;  // counted in ProcessFrame, after the snapshot is out
  if (report.group_closed) SaveMaps(false);
  if (report.edge_points == 0) events_.Increment("maps_key_frame_without_edges");
  if (report.view_skipped) events_.Increment("maps_view_without_objects");
  if (report.shifted) events_.Increment("maps_correlation_shifts");
  if (report.heading_turn_rad != 0) events_.Increment("maps_heading_turns");
  if (!key_frame.moving.empty()) events_.Increment("maps_key_frame_motion_masked");
  stage_ms_->Add("maps.key_frame",
                 std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  // While the robot stands at a stop, readers get the stop merged provisionally: a planner
  // wants what the robot sees now; the maps take the stop in for good when the base moves on.
  if (config_.maps.open_stop_in_maps && mapper_->standing_at_stop()) {
    const auto t1 = Clock::now();
    maps_ = mapper_->SnapshotWithOpenStop();
    stage_ms_->Add("maps.open_stop",
                   std::chrono::duration<double, std::milli>(Clock::now() - t1).count());
  } else {
    const auto t1 = Clock::now();
    maps_ = mapper_->Snapshot();
    stage_ms_->Add("maps.snapshot",
                   std::chrono::duration<double, std::milli>(Clock::now() - t1).count());
  }
  snapshot.maps = maps_;
}

}  // namespace epmap::mapping
