#include "services/mapping/pipeline/pipeline.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "perception/mobile_mapping/joint_limits.h"
#include "services/mapping/config/camera_chain.h"

namespace epmap::mapping {

namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// The configured camera describes an already-rectified pair.
std::pair<stereo::CameraParameters, stereo::CameraParameters> FromConfig(
    const ConfiguredCamera& c) {
  return camera::RectifiedPinholePair({c.width, c.height, c.fx, c.fy, c.cx, c.cy}, c.baseline_m);
}

double ValidShare(const cv::Mat& disparity) {
  size_t valid = 0;
  for (int r = 0; r < disparity.rows; ++r) {
    const float* row = disparity.ptr<float>(r);
    for (int c = 0; c < disparity.cols; ++c) valid += std::isfinite(row[c]) ? 1 : 0;
  }
  return disparity.empty() ? 0.0 : static_cast<double>(valid) / disparity.total();
}

}  // namespace

Pipeline::Pipeline(const ServiceConfig& config, BoundedQueue<StereoFrame>& queue,
                   SensorState& sensors, IngestCounters& counters, SnapshotStore& snapshots)
    : config_(config),
      queue_(queue),
      sensors_(sensors),
      counters_(counters),
      snapshots_(snapshots),
      matcher_(config.sgbm),
      ep_params_(MakeEpParams(config)) {
  if (!config.urdf.empty()) {
    chain_ = LoadCameraChain(config);
    spdlog::info("kinematic chain from {}: root '{}' to '{}'{}, joints [{}]", config.urdf,
                 chain_->root_link(), config.left_camera_link,
                 chain_->has_cam1() ? " and '" + config.right_camera_link + "'" : "",
                 fmt::join(chain_->joint_names(), ", "));
    if (!chain_->joint_names().empty()) {
      // The maps refuse key frames whose joints (the pan) read outside these limits.
      joint_limits_ = mobile_mapping::JointLimitsFromUrdfFile(config.urdf, chain_->joint_names());
    }
  }
  SetUpPoseSource();
  OpenMapsStore();
  ResumeSavedMaps();
}

void Pipeline::WarnOnce(const std::string& event, const std::string& message) {
  if (!warned_.insert(event).second) return;
  spdlog::warn("{}", message);
  events_.Increment(event);
}

void Pipeline::NoteOnce(const std::string& event, const std::string& message) {
  if (!warned_.insert(event).second) return;
  spdlog::info("{}", message);
  events_.Increment(event);
}

void Pipeline::WarnOnceIfTheImagesAreNotInTheUrdfCameraFrame(const std::string& image_frame_id) {
  if (image_frame_id.empty() || image_frame_id == config_.left_camera_link) return;
  WarnOnce("camera_frame_not_urdf_link:" + image_frame_id,
           fmt::format("the left images are in frame '{}' but the URDF's left camera link is "
                       "'{}' (robot.left_camera_link): the disparity is published in '{}', the "
                       "camera poses name '{}'",
                       image_frame_id, config_.left_camera_link, image_frame_id,
                       config_.left_camera_link));
}

void Pipeline::WarnOnceIfTheOdometryIsNotInTheConfiguredFrames() {
  const auto frames = sensors_.odometry_frames();
  if (!frames.frame_id.empty() && frames.frame_id != config_.maps.odom_frame) {
    WarnOnce("odometry_frame_not_odom_frame:" + frames.frame_id,
             fmt::format("rt/odom's poses are in frame '{}' but maps.odom_frame is '{}': the "
                         "map -> '{}' transform on rt/tf does not join the robot's tf tree",
                         frames.frame_id, config_.maps.odom_frame, config_.maps.odom_frame));
  }
}

bool Pipeline::ComposesThroughTheUrdf(const std::string& child) {
  if (child.empty() || child == chain_->root_link()) return false;
  if (!chain_->HasLink(child)) {
    WarnOnce("odometry_child_not_urdf_root:" + child,
             fmt::format("rt/odom moves frame '{}', which the URDF does not have (its root link "
                         "is '{}'): the maps take the odometry's pose for the URDF's root",
                         child, chain_->root_link()));
    return false;
  }
  // Whether the link can be placed depends on the tree, not on the joint values: zeros will do.
  const std::vector<double> zeros(chain_->joint_names().size(), 0.0);
  try {
    const Eigen::Vector3d t = chain_->LinkPose(child, zeros).translation();
    NoteOnce("odometry_child_composed:" + child,
             fmt::format("rt/odom moves frame '{}', a link of the URDF below its root '{}': the "
                         "root's pose is composed through the URDF ({:.3f}, {:.3f}, {:.3f}) m from "
                         "it at zero joints",
                         child, chain_->root_link(), t.x(), t.y(), t.z()));
    return true;
  } catch (const std::invalid_argument& e) {
    // A link behind a movable joint the service does not read (e.g. a wheel): its pose is unknown.
    WarnOnce("odometry_child_not_urdf_root:" + child,
             fmt::format("rt/odom moves frame '{}', which cannot be placed under the URDF's root "
                         "'{}' ({}): the maps take the odometry's pose for the URDF's root",
                         child, chain_->root_link(), e.what()));
    return false;
  }
}

Eigen::Isometry3d Pipeline::UrdfRootOnOdometry(const dds::PlanarOdometry& odom,
                                               const std::vector<double>& joints) {
  const Eigen::Isometry3d T_odom_child = internal_model::BaseOnOdometry(odom.x, odom.y, odom.theta);
  if (!chain_) return T_odom_child;
  // Resolved (and said) once per frame name, not every frame.
  std::string child = sensors_.odometry_frames().child_frame_id;
  if (!odometry_child_ || odometry_child_->name != child) {
    const bool composed = ComposesThroughTheUrdf(child);
    odometry_child_ = OdometryChild{std::move(child), composed};
  }
  if (!odometry_child_->composed) return T_odom_child;
  return internal_model::RootOnOdometry(T_odom_child,
                                        chain_->LinkPose(odometry_child_->name, joints));
}

Pipeline::~Pipeline() {
  Stop();
}

void Pipeline::Start() {
  stop_ = false;
  thread_ = std::thread([this] { Run(); });
}

void Pipeline::Stop() {
  stop_ = true;
  sensors_.Interrupt();
  if (thread_.joinable()) thread_.join();
  unexpected_hub_.Close();
  ApplyMapsReset();  // one asked for after the last frame
  SaveMaps(true);    // the stops merged since the last save (the thread is gone: no race)
  if (maps_store_) maps_store_->Flush();
}

std::string Pipeline::mode() const {
  if (config_.mode != "auto") return config_.mode;
  if (sensors_.has_odometry()) return "mobile-base";
  if (chain_) return "head";
  return "static";
}

void Pipeline::Run() {
  while (!stop_) {
    auto frame = queue_.Pop(std::chrono::milliseconds(100));
    if (!frame) continue;
    try {
      Process(*frame);
    } catch (const std::exception& e) {
      // A frame that breaks an algorithm is counted and skipped; the service keeps running.
      counters_.rejected.Increment("pipeline:exception");
      spdlog::warn("frame {} rejected: {}", frame->stamp_ns, e.what());
    }
  }
}

const stereo::Rectifier* Pipeline::CurrentRectifier(const StereoFrame& frame) {
  if (const auto model = active_models_ ? active_models_->stereo() : nullptr) {
    return StereoModelRectifier(frame, *model);
  }
  if (config_.camera.enabled) {
    if (!rectifier_) {
      const auto [l, r] = FromConfig(config_.camera);
      rectifier_.emplace(l, r);
    }
  } else {
    auto infos = sensors_.camera_infos();
    if (!infos.left || !infos.right) {
      // CameraInfo and images travel on different topics: give it a moment to arrive.
      const auto age = Clock::now() - frame.assembled;
      const auto wait = std::chrono::nanoseconds(config_.camera_info_wait_ns) - age;
      if (wait.count() > 0) sensors_.WaitForCameraInfos(wait);
      infos = sensors_.camera_infos();
    }
    if (!infos.left || !infos.right) {
      counters_.rejected.Increment("pipeline:no_camera_info");
      return nullptr;
    }
    if (infos.version != rectifier_version_) {
      try {
        rectifier_.emplace(*infos.left, *infos.right);
        rectifier_version_ = infos.version;
        spdlog::info("rectification from CameraInfo: {}x{}, fx {:.2f}, baseline {:.4f} m",
                     rectifier_->geometry().width, rectifier_->geometry().height,
                     rectifier_->geometry().fx, rectifier_->geometry().baseline_m);
      } catch (const std::invalid_argument& e) {
        rectifier_.reset();
        rectifier_version_ = infos.version;
        spdlog::warn("CameraInfo cannot rectify: {}", e.what());
      }
    }
    if (!rectifier_) {
      counters_.rejected.Increment("pipeline:camera_info_unusable");
      return nullptr;
    }
  }
  const auto& g = rectifier_->geometry();
  if (frame.left.cols != g.width || frame.left.rows != g.height) {
    counters_.rejected.Increment("pipeline:image_size_differs_from_camera_info");
    return nullptr;
  }
  return &*rectifier_;
}

void Pipeline::Process(StereoFrame& frame) {
  const auto t_start = Clock::now();
  if (frame_tap_) frame_tap_->Offer(frame);  // raw frames for stereo-extrinsics jobs
  const stereo::Rectifier* rectifier = CurrentRectifier(frame);
  if (!rectifier) return;

  auto t0 = Clock::now();
  cv::Mat left, right;
  rectifier->Rectify(frame.left, frame.right, left, right);
  stage_ms_->Add("rectify", MsSince(t0));

  t0 = Clock::now();
  std::string pose_reason;
  const auto pose = PoseAt(frame.stamp_ns, &pose_reason);
  stage_ms_->Add("pose", MsSince(t0));

  auto snapshot = std::make_shared<MapSnapshot>();
  snapshot->frame_index = processed_.load() + 1;
  snapshot->stamp_ns = frame.stamp_ns;
  snapshot->frame_id = frame.frame_id;
  snapshot->camera_link = config_.left_camera_link;
  if (chain_) {
    snapshot->base_frame = chain_->root_link();
    WarnOnceIfTheImagesAreNotInTheUrdfCameraFrame(frame.frame_id);
  }
  snapshot->camera = rectifier->geometry();
  snapshot->min_disparity = config_.sgbm.min_disparity;
  snapshot->num_disparities = config_.sgbm.num_disparities;
  snapshot->left_rectified = left;
  if (config_.ep.enabled) {
    RunExpectedPerception(frame, *rectifier, left, right, pose, pose_reason, *snapshot);
    if (!snapshot->ep) return;  // refused, counted
  } else {
    if (!pose && EffectivePoseSource() != "fixed") {
      events_.Increment("pose_unavailable:" + pose_reason);
    }
    t0 = Clock::now();
    snapshot->disparity = matcher_.Compute(left, right);
    stage_ms_->Add("sgbm", MsSince(t0));
    full_refreshes_++;
    if (pose) {
      snapshot->T_base_cam0 = pose->T_base_cam0;
      snapshot->T_odom_base = pose->T_odom_base;
    }
    snapshot->recomputed_share = 1.0;
  }
  if (config_.maps.enabled && mode() == "mobile-base") {
    t0 = Clock::now();
    RunMaps(frame, *rectifier, left, right, *snapshot);
    stage_ms_->Add("maps", MsSince(t0));
  }
  snapshot->valid_share = ValidShare(snapshot->disparity);
  stage_ms_->Add("total", MsSince(t_start));
  const double recomputed = snapshot->recomputed_share;
  const auto unexpected = snapshot->unexpected;
  snapshots_.Publish(std::move(snapshot));
  if (std::exchange(key_frame_awaits_publish_, false)) events_.Increment("maps_key_frames");
  if (unexpected) unexpected_hub_.Publish(unexpected);
  processed_++;
  figures_.Add("latency_ms", MsSince(frame.assembled));
  figures_.Add("recomputed_share", recomputed);
}

}  // namespace epmap::mapping
