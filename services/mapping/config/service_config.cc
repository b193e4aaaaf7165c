#include "services/mapping/config/service_config.h"

#include "perception/ep/ep_settings.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace epmap::mapping {

namespace {

// Reads the keys of one YAML mapping, remembering which were read so that leftovers (typos)
// can be reported.
class Section {
 public:
  // A missing or empty section (`robot:` with nothing under it) keeps every default.
  Section(const YAML::Node& node, std::string path)
      : node_(node), present_(node.IsDefined() && !node.IsNull()), path_(std::move(path)) {
    if (present_ && !node_.IsMap()) throw std::invalid_argument(path_ + ": expected a mapping");
  }

  // Call after reading every known key: a key nobody read is a typo or a stale setting.
  void RejectUnknownKeys() const {
    if (!present_) return;
    for (const auto& kv : node_) {
      const auto key = kv.first.as<std::string>();
      if (!seen_.count(key)) {
        throw std::invalid_argument("unknown setting '" + Join(key) + "'");
      }
    }
  }

  template <class T>
  void Get(const std::string& key, T& out) {
    seen_.insert(key);
    if (!present_) return;
    const YAML::Node value = node_[key];
    if (!value.IsDefined() || value.IsNull()) return;
    try {
      out = value.as<T>();
    } catch (const YAML::Exception&) {
      throw std::invalid_argument("setting '" + Join(key) + "' has the wrong type");
    }
  }
  // Durations are written in milliseconds in the file and kept in nanoseconds.
  void GetMs(const std::string& key, int64_t& out_ns) {
    double ms = static_cast<double>(out_ns) / 1e6;
    Get(key, ms);
    out_ns = static_cast<int64_t>(ms * 1e6);
  }
  Section Sub(const std::string& key) {
    seen_.insert(key);
    return Section(present_ ? node_[key] : YAML::Node(YAML::NodeType::Null), Join(key));
  }

 private:
  std::string Join(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  const YAML::Node node_;  // const: looking up a missing key must not create it
  bool present_;
  std::string path_;
  std::set<std::string> seen_;
};

void Apply(const YAML::Node& root, ServiceConfig& c) {
  Section top(root, "");
  {
    auto s = top.Sub("api");
    s.Get("listen", c.listen);
    s.Get("max_message_mb", c.max_message_mb);
    s.RejectUnknownKeys();
  }
  {
    auto s = top.Sub("dds");
    s.Get("domain", c.domain);
    s.Get("shared_memory_transport", c.shared_memory_transport);
    s.Get("max_image_bytes", c.max_image_bytes);
    auto t = s.Sub("topics");
    t.Get("left_image", c.topics.left_image);
    t.Get("right_image", c.topics.right_image);
    t.Get("left_camera_info", c.topics.left_info);
    t.Get("right_camera_info", c.topics.right_info);
    t.Get("joint_states", c.topics.joints);
    t.Get("odometry", c.topics.odom);
    t.Get("eye_hand_samples", c.topics.eye_hand_samples);
    t.Get("map", c.topics.map);
    t.Get("tf", c.topics.tf);
    t.Get("perceptual_map", c.topics.perceptual_map);
    t.Get("disparity", c.topics.disparity);
    t.Get("unexpected_mask", c.topics.unexpected_mask);
    t.RejectUnknownKeys();
    s.RejectUnknownKeys();
  }
  {
    auto s = top.Sub("ingest");
    s.GetMs("pair_tolerance_ms", c.pair_tolerance_ns);
    s.GetMs("pair_timeout_ms", c.pair_timeout_ns);
    s.GetMs("camera_info_wait_ms", c.camera_info_wait_ns);
    s.GetMs("joints_max_gap_ms", c.joints_max_gap_ns);
    s.GetMs("joints_wait_ms", c.joints_wait_ns);
    s.Get("queue_capacity", c.queue_capacity);
    s.RejectUnknownKeys();
  }
  {
    auto s = top.Sub("robot");
    s.Get("mode", c.mode);
    s.Get("urdf", c.urdf);
    s.Get("urdf_topic", c.urdf_topic);
    s.GetMs("urdf_topic_wait_ms", c.urdf_topic_wait_ns);
    s.Get("left_camera_link", c.left_camera_link);
    s.Get("right_camera_link", c.right_camera_link);
    auto cam = s.Sub("camera");
    cam.Get("enabled", c.camera.enabled);
    cam.Get("width", c.camera.width);
    cam.Get("height", c.camera.height);
    cam.Get("fx", c.camera.fx);
    cam.Get("fy", c.camera.fy);
    cam.Get("cx", c.camera.cx);
    cam.Get("cy", c.camera.cy);
    cam.Get("baseline_m", c.camera.baseline_m);
    cam.RejectUnknownKeys();
    s.RejectUnknownKeys();
  }
  {
    auto s = top.Sub("stereo");
    s.Get("min_disparity", c.sgbm.min_disparity);
    s.Get("num_disparities", c.sgbm.num_disparities);
    s.Get("block_size", c.sgbm.block_size);
    s.Get("p1", c.sgbm.p1);
    s.Get("p2", c.sgbm.p2);
    s.Get("uniqueness_ratio", c.sgbm.uniqueness_ratio);
    s.Get("speckle_window", c.sgbm.speckle_window);
    s.Get("speckle_range", c.sgbm.speckle_range);
    s.Get("disp12_max_diff", c.sgbm.disp12_max_diff);
    s.Get("pre_filter_cap", c.sgbm.pre_filter_cap);
    s.Get("mode", c.sgbm.mode);
    s.RejectUnknownKeys();
  }
  {
    auto s = top.Sub("state");
    s.Get("dir", c.state_dir);
    s.RejectUnknownKeys();
  }
  {
    auto s = top.Sub("calibration");
    s.Get("worker_threads", c.calibration.worker_threads);
    s.Get("stereo_frames", c.calibration.stereo_frames);
    s.GetMs("stereo_frame_timeout_ms", c.calibration.stereo_frame_timeout_ns);
    s.GetMs("stereo_frame_interval_ms", c.calibration.stereo_frame_interval_ns);
    s.Get("stereo_min_success_share", c.calibration.stereo_min_success_share);
    s.Get("baseline_direction_prior_sigma_deg", c.calibration.baseline_direction_prior_sigma_deg);
    s.Get("rectification_rebuild_deg", c.calibration.rectification_rebuild_deg);
    s.RejectUnknownKeys();
  }
  {
    auto s = top.Sub("ep");
    s.Get("enabled", c.ep.enabled);
    s.Get("pose_source", c.ep.pose_source);
    s.Get("learned_model", c.ep.learned_model);
    s.Get("params", c.ep.params);
    s.RejectUnknownKeys();
  }
  {
    auto s = top.Sub("maps");
    s.Get("enabled", c.maps.enabled);
    s.Get("key_frame_min_translation_m", c.maps.key_frame_min_translation_m);
    s.Get("key_frame_min_rotation_rad", c.maps.key_frame_min_rotation_rad);
    s.Get("key_frame_min_pan_rad", c.maps.key_frame_min_pan_rad);
    s.Get("visual_heading", c.maps.visual_heading);
    s.Get("map_correlation", c.maps.map_correlation);
    s.Get("odometry_drift_per_m", c.maps.odometry_drift_per_m);
    s.Get("heading_registration_step_deg", c.maps.heading_registration_step_deg);
    s.Get("grid_resolution_m", c.maps.grid_resolution_m);
    s.Get("place_views_by_pose", c.maps.place_views_by_pose);
    s.Get("view_min_key_frames", c.maps.view_min_key_frames);
    s.Get("max_odometry_step_m", c.maps.max_odometry_step_m);
    s.Get("max_odometry_step_rad", c.maps.max_odometry_step_rad);
    s.Get("max_odometry_speed_mps", c.maps.max_odometry_speed_mps);
    s.Get("open_stop_in_maps", c.maps.open_stop_in_maps);
    s.Get("reference_skip_from_height_m", c.maps.reference_skip_from_height_m);
    s.Get("reference_skip_to_height_m", c.maps.reference_skip_to_height_m);
    s.Get("map_frame", c.maps.map_frame);
    s.Get("odom_frame", c.maps.odom_frame);
    s.Get("grid_publish_period_s", c.maps.grid_publish_period_s);
    s.Get("persist", c.maps.persist);
    s.Get("save_period_s", c.maps.save_period_s);
    s.RejectUnknownKeys();
  }
  {
    auto s = top.Sub("log");
    s.Get("level", c.log_level);
    s.RejectUnknownKeys();
  }
  top.RejectUnknownKeys();
}

}  // namespace

void ServiceConfig::Validate() const {
  const auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (listen.empty() || listen.find(':') == std::string::npos) {
    bad("api.listen must be host:port, got '" + listen + "'");
  }
  if (max_message_mb < 4 || max_message_mb > 1024) bad("api.max_message_mb must be 4..1024");
  if (domain > 232) bad("dds.domain must be 0..232");
  if (max_image_bytes < 1024) bad("dds.max_image_bytes is too small");
  if (queue_capacity < 1 || queue_capacity > 1024) bad("ingest.queue_capacity must be 1..1024");
  if (pair_tolerance_ns < 0 || pair_timeout_ns <= 0) bad("ingest pairing times must be positive");
  static const std::set<std::string> kModes{"auto", "head", "static", "mobile-base"};
  if (!kModes.count(mode)) bad("robot.mode must be auto, head, static or mobile-base");
  if (!urdf.empty() && !urdf_topic.empty()) {
    bad("robot.urdf and robot.urdf_topic are exclusive: the URDF comes from a file or a topic");
  }
  if (!urdf_topic.empty() && urdf_topic_wait_ns <= 0) {
    bad("robot.urdf_topic_wait_ms must be positive");
  }
  if (left_camera_link.empty() || right_camera_link.empty()) {
    bad("robot.left_camera_link and robot.right_camera_link must name URDF links");
  }
  if (left_camera_link == right_camera_link) {
    bad("robot.left_camera_link and robot.right_camera_link must differ, both are '" +
        left_camera_link + "'");
  }
  if (camera.enabled && (camera.width <= 0 || camera.height <= 0 || camera.fx <= 0 ||
                         camera.fy <= 0 || camera.baseline_m <= 0)) {
    bad("robot.camera: width, height, fx, fy and baseline_m must be positive when enabled");
  }
  {
    const auto& k = calibration;
    if (k.worker_threads < 1 || k.worker_threads > 16) {
      bad("calibration.worker_threads must be 1..16");
    }
    if (k.stereo_frames < 1 || k.stereo_frames > 1000) {
      bad("calibration.stereo_frames must be 1..1000");
    }
    if (k.stereo_frame_timeout_ns <= 0) bad("calibration.stereo_frame_timeout_ms must be positive");
    if (k.stereo_frame_interval_ns < 0) bad("calibration.stereo_frame_interval_ms must be >= 0");
    if (!(k.stereo_min_success_share > 0 && k.stereo_min_success_share <= 1)) {
      bad("calibration.stereo_min_success_share must be in (0, 1]");
    }
    if (!(k.baseline_direction_prior_sigma_deg >= 0)) {
      bad("calibration.baseline_direction_prior_sigma_deg must be >= 0 (0 = off)");
    }
    if (!(k.rectification_rebuild_deg > 0)) {
      bad("calibration.rectification_rebuild_deg must be > 0");
    }
  }
  static const std::set<std::string> kPoseSources{"auto", "urdf", "learned", "odometry", "fixed"};
  if (!kPoseSources.count(ep.pose_source)) {
    bad("ep.pose_source must be auto, urdf, learned, odometry or fixed");
  }
  if (ep.pose_source == "learned" && ep.learned_model.empty()) {
    bad("ep.pose_source learned needs ep.learned_model (a file saved by epmap-bench ep "
        "--internal-model learned --out DIR)");
  }
  try {
    MakeEpParams(*this).Validate();
  } catch (const std::invalid_argument& e) {
    bad(std::string("ep.params: ") + e.what());
  }
  {
    const auto& m = maps;
    if (!(m.key_frame_min_translation_m > 0) || !(m.key_frame_min_rotation_rad > 0) ||
        !(m.key_frame_min_pan_rad > 0)) {
      bad("maps.key_frame_min_translation_m, key_frame_min_rotation_rad and key_frame_min_pan_rad "
          "must be positive");
    }
    if (m.view_min_key_frames < 0) bad("maps.view_min_key_frames must be >= 0 (0 = automatic)");
    if (!(m.odometry_drift_per_m >= 0) || !std::isfinite(m.odometry_drift_per_m)) {
      bad("maps.odometry_drift_per_m must be >= 0 and finite (0 = every shift taken whole)");
    }
    if (!(m.heading_registration_step_deg >= 0 && m.heading_registration_step_deg <= 5)) {
      bad("maps.heading_registration_step_deg must be between 0 (off) and 5 degrees");
    }
    // Finer cells multiply the ray traversal and the memory; coarser ones hide doorways.
    if (!(m.grid_resolution_m >= 0.02 && m.grid_resolution_m <= 1.0)) {
      bad("maps.grid_resolution_m must be between 0.02 and 1 m");
    }
    if (!(m.max_odometry_step_m > 0) || !(m.max_odometry_step_rad > 0) ||
        !(m.max_odometry_speed_mps > 0)) {
      bad("maps.max_odometry_step_m, max_odometry_step_rad and max_odometry_speed_mps must be "
          "positive");
    }
    if (!std::isfinite(m.reference_skip_from_height_m) ||
        !std::isfinite(m.reference_skip_to_height_m)) {
      bad("maps.reference_skip_from_height_m and reference_skip_to_height_m must be finite");
    }
    if (m.map_frame.empty() || m.odom_frame.empty() || m.map_frame == m.odom_frame) {
      bad("maps.map_frame and maps.odom_frame must be two different, non-empty frame names");
    }
    if (!(m.grid_publish_period_s > 0) || !std::isfinite(m.grid_publish_period_s)) {
      bad("maps.grid_publish_period_s must be a positive number of seconds");
    }
    if (!(m.save_period_s >= 0) || !std::isfinite(m.save_period_s)) {
      bad("maps.save_period_s must be a number of seconds >= 0");
    }
  }
  static const std::set<std::string> kLevels{"trace", "debug", "info", "warn", "error"};
  if (!kLevels.count(log_level)) bad("log.level must be trace, debug, info, warn or error");
  try {
    sgbm.Validate();
  } catch (const std::invalid_argument& e) {
    bad(std::string("stereo: ") + e.what());
  }
  for (const auto* topic : {&topics.left_image, &topics.right_image, &topics.left_info,
                            &topics.right_info, &topics.joints, &topics.odom}) {
    if (topic->empty()) bad("dds.topics: a topic name is empty");
  }
}

void ApplyYaml(const std::string& yaml_text, ServiceConfig& config) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument(std::string("YAML error: ") + e.what());
  }
  if (root.IsNull()) return;
  Apply(root, config);
}

ep::EpParams MakeEpParams(const ServiceConfig& config) {
  ep::EpParams params;
  for (const auto& [key, value] : config.ep.params) {
    if (key.rfind("sgbm.", 0) == 0) {
      throw std::invalid_argument("'" + key + "': SGBM is configured in the stereo section");
    }
    ep::SetEpParam(&params, key, value);
  }
  params.sgbm = config.sgbm;
  return params;
}

ServiceConfig LoadServiceConfig(const std::filesystem::path& yaml_path) {
  std::ifstream in(yaml_path);
  if (!in) throw std::invalid_argument("cannot open config " + yaml_path.string());
  std::stringstream text;
  text << in.rdbuf();
  ServiceConfig config;
  try {
    ApplyYaml(text.str(), config);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(yaml_path.string() + ": " + e.what());
  }
  return config;
}

std::string ToYaml(const ServiceConfig& c) {
  YAML::Emitter out;
  // 15 significant digits: 0.1 reads back as 0.1, not as 0.10000000000000001.
  out.SetDoublePrecision(15);
  out << YAML::BeginMap;
  out << YAML::Key << "api" << YAML::Value << YAML::BeginMap << YAML::Key << "listen" << YAML::Value
      << c.listen << YAML::Key << "max_message_mb" << YAML::Value << c.max_message_mb
      << YAML::EndMap;
  out << YAML::Key << "dds" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "domain" << YAML::Value << c.domain;
  out << YAML::Key << "shared_memory_transport" << YAML::Value << c.shared_memory_transport;
  out << YAML::Key << "max_image_bytes" << YAML::Value << c.max_image_bytes;
  out << YAML::Key << "topics" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "left_image" << YAML::Value << c.topics.left_image;
  out << YAML::Key << "right_image" << YAML::Value << c.topics.right_image;
  out << YAML::Key << "left_camera_info" << YAML::Value << c.topics.left_info;
  out << YAML::Key << "right_camera_info" << YAML::Value << c.topics.right_info;
  out << YAML::Key << "joint_states" << YAML::Value << c.topics.joints;
  out << YAML::Key << "odometry" << YAML::Value << c.topics.odom;
  out << YAML::Key << "eye_hand_samples" << YAML::Value << c.topics.eye_hand_samples;
  out << YAML::Key << "map" << YAML::Value << c.topics.map;
  out << YAML::Key << "tf" << YAML::Value << c.topics.tf;
  out << YAML::Key << "perceptual_map" << YAML::Value << c.topics.perceptual_map;
  out << YAML::Key << "disparity" << YAML::Value << c.topics.disparity;
  out << YAML::Key << "unexpected_mask" << YAML::Value << c.topics.unexpected_mask;
  out << YAML::EndMap << YAML::EndMap;
  out << YAML::Key << "ingest" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "pair_tolerance_ms" << YAML::Value << c.pair_tolerance_ns / 1e6;
  out << YAML::Key << "pair_timeout_ms" << YAML::Value << c.pair_timeout_ns / 1e6;
  out << YAML::Key << "camera_info_wait_ms" << YAML::Value << c.camera_info_wait_ns / 1e6;
  out << YAML::Key << "joints_max_gap_ms" << YAML::Value << c.joints_max_gap_ns / 1e6;
  out << YAML::Key << "joints_wait_ms" << YAML::Value << c.joints_wait_ns / 1e6;
  out << YAML::Key << "queue_capacity" << YAML::Value << c.queue_capacity;
  out << YAML::EndMap;
  out << YAML::Key << "robot" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "mode" << YAML::Value << c.mode;
  out << YAML::Key << "urdf" << YAML::Value << c.urdf;
  out << YAML::Key << "urdf_topic" << YAML::Value << c.urdf_topic;
  out << YAML::Key << "urdf_topic_wait_ms" << YAML::Value << c.urdf_topic_wait_ns / 1e6;
  out << YAML::Key << "left_camera_link" << YAML::Value << c.left_camera_link;
  out << YAML::Key << "right_camera_link" << YAML::Value << c.right_camera_link;
  out << YAML::Key << "camera" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "enabled" << YAML::Value << c.camera.enabled;
  out << YAML::Key << "width" << YAML::Value << c.camera.width;
  out << YAML::Key << "height" << YAML::Value << c.camera.height;
  out << YAML::Key << "fx" << YAML::Value << c.camera.fx;
  out << YAML::Key << "fy" << YAML::Value << c.camera.fy;
  out << YAML::Key << "cx" << YAML::Value << c.camera.cx;
  out << YAML::Key << "cy" << YAML::Value << c.camera.cy;
  out << YAML::Key << "baseline_m" << YAML::Value << c.camera.baseline_m;
  out << YAML::EndMap << YAML::EndMap;
  out << YAML::Key << "stereo" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "min_disparity" << YAML::Value << c.sgbm.min_disparity;
  out << YAML::Key << "num_disparities" << YAML::Value << c.sgbm.num_disparities;
  out << YAML::Key << "block_size" << YAML::Value << c.sgbm.block_size;
  out << YAML::Key << "p1" << YAML::Value << c.sgbm.p1;
  out << YAML::Key << "p2" << YAML::Value << c.sgbm.p2;
  out << YAML::Key << "uniqueness_ratio" << YAML::Value << c.sgbm.uniqueness_ratio;
  out << YAML::Key << "speckle_window" << YAML::Value << c.sgbm.speckle_window;
  out << YAML::Key << "speckle_range" << YAML::Value << c.sgbm.speckle_range;
  out << YAML::Key << "disp12_max_diff" << YAML::Value << c.sgbm.disp12_max_diff;
  out << YAML::Key << "pre_filter_cap" << YAML::Value << c.sgbm.pre_filter_cap;
  out << YAML::Key << "mode" << YAML::Value << c.sgbm.mode;
  out << YAML::EndMap;
  out << YAML::Key << "state" << YAML::Value << YAML::BeginMap << YAML::Key << "dir" << YAML::Value
      << c.state_dir << YAML::EndMap;
  out << YAML::Key << "calibration" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "worker_threads" << YAML::Value << c.calibration.worker_threads;
  out << YAML::Key << "stereo_frames" << YAML::Value << c.calibration.stereo_frames;
  out << YAML::Key << "stereo_frame_timeout_ms" << YAML::Value
      << c.calibration.stereo_frame_timeout_ns / 1e6;
  out << YAML::Key << "stereo_frame_interval_ms" << YAML::Value
      << c.calibration.stereo_frame_interval_ns / 1e6;
  out << YAML::Key << "stereo_min_success_share" << YAML::Value
      << c.calibration.stereo_min_success_share;
  out << YAML::Key << "baseline_direction_prior_sigma_deg" << YAML::Value
      << c.calibration.baseline_direction_prior_sigma_deg;
  out << YAML::Key << "rectification_rebuild_deg" << YAML::Value
      << c.calibration.rectification_rebuild_deg;
  out << YAML::EndMap;
  out << YAML::Key << "ep" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "enabled" << YAML::Value << c.ep.enabled;
  out << YAML::Key << "pose_source" << YAML::Value << c.ep.pose_source;
  out << YAML::Key << "learned_model" << YAML::Value << c.ep.learned_model;
  out << YAML::Key << "params" << YAML::Value << YAML::BeginMap;
  for (const auto& [key, value] : c.ep.params) out << YAML::Key << key << YAML::Value << value;
  out << YAML::EndMap << YAML::EndMap;
  out << YAML::Key << "maps" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "enabled" << YAML::Value << c.maps.enabled;
  out << YAML::Key << "key_frame_min_translation_m" << YAML::Value
      << c.maps.key_frame_min_translation_m;
  out << YAML::Key << "key_frame_min_rotation_rad" << YAML::Value
      << c.maps.key_frame_min_rotation_rad;
  out << YAML::Key << "key_frame_min_pan_rad" << YAML::Value << c.maps.key_frame_min_pan_rad;
  out << YAML::Key << "visual_heading" << YAML::Value << c.maps.visual_heading;
  out << YAML::Key << "map_correlation" << YAML::Value << c.maps.map_correlation;
  out << YAML::Key << "odometry_drift_per_m" << YAML::Value << c.maps.odometry_drift_per_m;
  out << YAML::Key << "heading_registration_step_deg" << YAML::Value
      << c.maps.heading_registration_step_deg;
  out << YAML::Key << "grid_resolution_m" << YAML::Value << c.maps.grid_resolution_m;
  out << YAML::Key << "place_views_by_pose" << YAML::Value << c.maps.place_views_by_pose;
  out << YAML::Key << "view_min_key_frames" << YAML::Value << c.maps.view_min_key_frames;
  out << YAML::Key << "max_odometry_step_m" << YAML::Value << c.maps.max_odometry_step_m;
  out << YAML::Key << "max_odometry_step_rad" << YAML::Value << c.maps.max_odometry_step_rad;
  out << YAML::Key << "max_odometry_speed_mps" << YAML::Value << c.maps.max_odometry_speed_mps;
  out << YAML::Key << "open_stop_in_maps" << YAML::Value << c.maps.open_stop_in_maps;
  out << YAML::Key << "reference_skip_from_height_m" << YAML::Value
      << c.maps.reference_skip_from_height_m;
  out << YAML::Key << "reference_skip_to_height_m" << YAML::Value
      << c.maps.reference_skip_to_height_m;
  out << YAML::Key << "map_frame" << YAML::Value << c.maps.map_frame;
  out << YAML::Key << "odom_frame" << YAML::Value << c.maps.odom_frame;
  out << YAML::Key << "grid_publish_period_s" << YAML::Value << c.maps.grid_publish_period_s;
  out << YAML::Key << "persist" << YAML::Value << c.maps.persist;
  out << YAML::Key << "save_period_s" << YAML::Value << c.maps.save_period_s;
  out << YAML::EndMap;
  out << YAML::Key << "log" << YAML::Value << YAML::BeginMap << YAML::Key << "level" << YAML::Value
      << c.log_level << YAML::EndMap;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace epmap::mapping
