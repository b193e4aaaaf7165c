#pragma once
// epmapd's configuration: every setting with its default, loadable from YAML and overridable
// by command-line flags. deploy/epmapd.yaml documents every key with its default; a test keeps
// that file and these defaults in step.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "common/dds/topics.h"
#include "perception/ep/expected_perception.h"
#include "perception/stereo/sgbm.h"

namespace epmap::mapping {

// Where the rectification comes from when no CameraInfo has arrived (or when told to ignore it).
struct ConfiguredCamera {
  bool enabled = false;  // true: use these values instead of waiting for CameraInfo
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double baseline_m = 0;  // the pair is taken as already rectified
};

// The calibration service (services/mapping/calibration/README.md).
struct CalibrationSettings {
  int worker_threads = 1;                            // jobs run on these, never on gRPC threads
  uint32_t stereo_frames = 10;                       // frames a stereo job uses by default
  int64_t stereo_frame_timeout_ns = 10'000'000'000;  // no frame for this long: the job fails
  int64_t stereo_frame_interval_ns = 200'000'000;    // frames used at least this far apart
  double stereo_min_success_share = 0.5;             // share of frames that must self-calibrate
  // Optional Gaussian prior on the baseline direction (perception/calibration README); 0 = off,
  // the paper's procedure (data only).
  double baseline_direction_prior_sigma_deg = 0.0;
  // With a stereo model active, the rectification maps are rebuilt when the frame's extrinsics
  // differ from the maps' by more than this (rotation or baseline direction).
  double rectification_rebuild_deg = 0.01;
};

// The expected-perception disparity map (perception/ep/README.md).
struct EpSettings {
  bool enabled =
      true;  // false: full-frame SGBM on every frame (the baseline EP is measured against)
  // Where the camera pose comes from (paper 000's internal model): urdf (forward kinematics of
  // robot.urdf), learned (the paper's MLP, loaded from learned_model), odometry (the base's
  // odometry composed with the URDF's base->camera chain), fixed (a static rig), or auto: urdf
  // when a URDF is given, else fixed.
  std::string pose_source = "auto";
  // pose_source learned: a model saved by `epmap-bench ep --internal-model learned --out DIR`
  // (DIR/learned_model.yml).
  std::string learned_model;
  // Any perception/ep parameter by name (`epmap-bench ep --list-params` lists them), e.g.
  // "comparator.threshold_grey": "12". The SGBM parameters come from the stereo section.
  std::map<std::string, std::string> params;
};

// The maps of a mobile base (issue 6; perception/mobile_mapping/README.md): built in
// mobile-base mode from the rectified images, rt/odom and the head's joints.
struct MapsSettings {
  bool enabled = true;  // false: no maps in mobile-base mode (the RPCs answer FAILED_PRECONDITION)
  // A frame becomes a key frame when, since the last one, the base moved or turned or the head
  // panned this much (mobile_mapping::KeyFrameSelectorParams).
  double key_frame_min_translation_m = 0.25;
  double key_frame_min_rotation_rad = 0.15;
  double key_frame_min_pan_rad = 0.15;
  bool visual_heading = true;   // paper 002, Sec. 3.3: heading corrected from the images
  bool map_correlation = true;  // paper 002, Sec. 4: position corrected at each stop
  // How much the base's odometry drifts per metre driven: each correlation shift is weighed
  // against it (mobile_mapping::MobileMapperParams::odometry_drift_per_m); 0 takes every
  // shift whole, as paper 002 does.
  double odometry_drift_per_m = 0.02;
  // Beyond paper 002: at each stop the heading is also registered against the global map, the
  // local map turned by +-this angle (mobile_mapping::MobileMapperParams::
  // correlation_heading_step_rad); it keeps the visual heading from drifting over long runs.
  // 0: off (paper 002, heading from vision alone).
  double heading_registration_step_deg = 0.5;
  // Cell size of the occupancy grid (occupancy::GridParams::resolution_m). 0.1 m is about the
  // rig's depth noise at 3-4 m; 0.125-0.2 m cells scored no better against the building's
  // walls on all four runs (perception/mobile_mapping/EXPERIMENTS.md).
  double grid_resolution_m = 0.1;
  // Perceptual-map views placed by the corrected pose; false: triangulated from the nearest
  // common object, as paper 003 Sec. III-C (perceptual_map::PerceptualMapParams).
  bool place_views_by_pose = true;
  // Key frames at one stop that make a perceptual-map view; 0 = automatic (1 until the head
  // is seen panning at a stop, then 2: only panning stops make views).
  int view_min_key_frames = 0;
  // Key frames whose odometry moved more than this since the last accepted one are refused
  // (a glitch, counted in GetStatus key_frames_refused_by_reason as maps:odometry_jump).
  double max_odometry_step_m = 2.0;
  double max_odometry_step_rad = 1.6;
  double max_odometry_speed_mps = 3.0;
  // While the base stands at a stop, the maps served include that stop provisionally (rebuilt
  // at each key frame: a copy of the maps and a registration); false: a stop shows only once
  // the base moves on.
  bool open_stop_in_maps = true;
  // Perceptual-map reference points are taken from every height but this band above the floor
  // (furniture; mobile_mapping::MobileMapperParams). from >= to: no band.
  double reference_skip_from_height_m = 0.3;
  double reference_skip_to_height_m = 1.2;
  // ROS output (dds.topics.map / dds.topics.tf): the grid's frame, and the frame rt/odom's
  // poses are in; map -> odom on tf is the correction (corrected pose x odometry pose^-1).
  std::string map_frame = "map";
  std::string odom_frame = "odom";
  double grid_publish_period_s = 1.0;  // the grid at most this often (it changes per key frame)
  // Durable maps (needs state.dir): the maps are saved to <state.dir>/maps.sqlite3 when a stop
  // has joined them, at most every save_period_s, and at shutdown; a restarted epmapd resumes
  // them when its first key frame continues the saved run (same odometry frame: later stamp, no
  // jump; mobile_mapping::MobileMapper::RestoreState), else starts new ones. false: neither.
  bool persist = true;
  double save_period_s = 5.0;
};

struct ServiceConfig {
  // --- API ---
  std::string listen = "127.0.0.1:50051";  // gRPC address
  int max_message_mb = 64;                 // gRPC send/receive limit (a 640x480 map is 1.2 MB)

  // --- DDS ingest ---
  uint32_t domain = 0;
  dds::TopicNames topics;
  bool shared_memory_transport = true;          // 16 MiB segment for same-host publishers
  uint32_t max_image_bytes = 32u << 20;         // larger samples are refused before decoding
  int64_t pair_tolerance_ns = 2'000'000;        // left/right stamps closer than this form a pair
  int64_t pair_timeout_ns = 500'000'000;        // an image without partner for this long is dropped
  int64_t camera_info_wait_ns = 1'000'000'000;  // how long a frame may wait for CameraInfo
  int64_t joints_max_gap_ns = 200'000'000;  // joint readings must bracket the image this closely
  int64_t joints_wait_ns = 100'000'000;     // wait this long for a reading after the image stamp
  size_t queue_capacity = 4;  // frames between ingest and pipeline: ~0.13 s at 30 Hz absorbs a
                              // slow frame; more only adds latency once the pipeline falls behind

  // --- robot ---
  std::string mode = "auto";  // auto | head | static | mobile-base
  std::string urdf;           // kinematic chain from the base to the cameras' optical links
  // Or the URDF as robot_state_publisher latches it (std_msgs/String, transient local), e.g.
  // "rt/robot_description": epmapd waits for it at start, up to urdf_topic_wait, and fails
  // clearly without it. Exclusive with urdf.
  std::string urdf_topic;
  int64_t urdf_topic_wait_ns = 10'000'000'000;
  // The URDF's links of the two cameras' optical frames (x right, y down, z forward); the
  // defaults are the dataset layout's names, a robot's own URDF usually has others.
  std::string left_camera_link = "cam0_optical";
  std::string right_camera_link = "cam1_optical";
  ConfiguredCamera camera;

  // --- stereo ---
  stereo::SgbmParams sgbm;  // defaults: ../shared/data README's reference values

  // --- durable state ---
  std::string state_dir;  // empty: no durable state (calibration disabled)

  // --- calibration service ---
  CalibrationSettings calibration;

  // --- expected perception ---
  EpSettings ep;

  // --- maps (mobile-base mode) ---
  MapsSettings maps;

  // --- logging ---
  std::string log_level = "info";  // trace | debug | info | warn | error

  // Throws std::invalid_argument naming the first bad setting.
  void Validate() const;
};

// The EP parameters: the defaults, overridden by ep.params, with the stereo section's SGBM.
// Throws std::invalid_argument naming an unknown key or a value that does not parse.
ep::EpParams MakeEpParams(const ServiceConfig& config);

// Loads YAML over the defaults; unknown keys are an error (a typo must not pass silently).
ServiceConfig LoadServiceConfig(const std::filesystem::path& yaml_path);
// Applies YAML text over `config` (used by LoadServiceConfig and tests).
void ApplyYaml(const std::string& yaml_text, ServiceConfig& config);
// The effective configuration as YAML (epmapd --print-config).
std::string ToYaml(const ServiceConfig& config);

}  // namespace epmap::mapping
