// The pipeline's expected-perception stage (paper 000; perception/ep): the camera pose from the
// internal model (URDF chain, learned MLP, odometry or a fixed rig), then the EP map instead of
// full-frame SGBM, and the regions that moved on its own for MapService and WatchUnexpected.

#include <spdlog/spdlog.h>

#include <cmath>

#include "services/mapping/pipeline/pipeline.h"
#include "services/mapping/pipeline/rectified_camera.h"

namespace epmap::mapping {

namespace {

const char* EventName(ep::FrameMode mode) {
  switch (mode) {
    case ep::FrameMode::kFirst:
      return "ep_full_first_frame";
    case ep::FrameMode::kPredicted:
      return "";
    case ep::FrameMode::kRefreshScheduled:
      return "ep_full_refresh_scheduled";
    case ep::FrameMode::kRefreshShare:
      return "ep_full_refresh_share";
    case ep::FrameMode::kPoseJump:
      return "ep_pose_jump";
  }
  return "";
}

}  // namespace

void Pipeline::SetUpPoseSource() {
  pose_source_ = config_.ep.pose_source;
  if (pose_source_ == "urdf" && !chain_) {
    throw std::runtime_error("ep.pose_source urdf needs robot.urdf (--urdf)");
  }
  if (pose_source_ == "odometry" && !chain_) {
    throw std::runtime_error(
        "ep.pose_source odometry needs robot.urdf (the chain from the base to the left camera)");
  }
  if (pose_source_ == "learned") {
    try {
      auto model = internal_model::LearnedPoseModel::Load(config_.ep.learned_model);
      learned_inputs_ = model.input_joint_names();
      learned_.emplace(std::move(model), learned_inputs_);
    } catch (const std::exception& e) {
      throw std::runtime_error("ep.learned_model: " + std::string(e.what()));
    }
    spdlog::info("internal model: learned MLP from {} (inputs {})", config_.ep.learned_model,
                 fmt::join(learned_inputs_, ", "));
  }
}

std::string Pipeline::EffectivePoseSource() const {
  if (pose_source_ != "auto") return pose_source_;
  if (chain_ && sensors_.has_odometry()) return "odometry";
  if (chain_) return "urdf";
  return "fixed";
}

std::optional<FramePose> Pipeline::PoseAt(int64_t stamp_ns, std::string* reason) {
  const std::string source = EffectivePoseSource();
  if (source == "fixed") return FramePose{};
  const auto wait = std::chrono::nanoseconds(config_.joints_wait_ns);
  if (source == "learned") {
    const auto joints =
        sensors_.JointsAt(stamp_ns, learned_inputs_, config_.joints_max_gap_ns, wait, reason);
    if (!joints) return std::nullopt;
    return FramePose{learned_->CameraPose({*joints, std::nullopt}), std::nullopt};
  }
  // urdf and odometry: the chain from the base to the left camera (robot.left_camera_link).
  const auto joints =
      sensors_.JointsAt(stamp_ns, chain_->joint_names(), config_.joints_max_gap_ns, wait, reason);
  if (!joints) return std::nullopt;
  FramePose pose;
  pose.T_base_cam0 = chain_->Cam0Pose(*joints);
  if (source == "urdf") return pose;
  // odometry: the base's (the URDF root's) planar pose in the odometry frame, then the chain.
  const auto odom = sensors_.OdometryAt(stamp_ns, config_.joints_max_gap_ns, wait, reason);
  if (!odom) return std::nullopt;
  pose.T_odom_base = UrdfRootOnOdometry(*odom, *joints);
  return pose;
}

void Pipeline::RunExpectedPerception(const StereoFrame& frame, const stereo::Rectifier& rectifier,
                                     const cv::Mat& left, const cv::Mat& right,
                                     const std::optional<FramePose>& raw_pose,
                                     const std::string& pose_reason, MapSnapshot& snapshot) {
  const stereo::RectifiedGeometry& geometry = rectifier.geometry();
  if (!ep_ || !SameGeometry(ep_->camera(), geometry)) {
    if (ep_) events_.Increment("ep_restarted_new_rectification");
    ep_ = std::make_unique<ep::ExpectedPerception>(geometry, ep_params_);
  }
  // The rectified left camera's pose: the raw camera's, turned by the rectification; the EP
  // predicts in the frame where the world stands still (odometry's on a mobile base).
  Eigen::Isometry3d T_base_rect = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> T_odom_base;
  if (raw_pose) {
    T_base_rect = raw_pose->T_base_cam0 * RawToRectified(rectifier);
    T_odom_base = raw_pose->T_odom_base;
  } else {
    // Without a pose nothing can be predicted: the map restarts from this frame, computed whole.
    events_.Increment("ep_restart_no_pose:" + pose_reason);
    ep_->Reset();
  }

  std::shared_ptr<const ep::EpResult> result;
  try {
    result = ep_->Process(left, right, T_odom_base ? *T_odom_base * T_base_rect : T_base_rect,
                          frame.stamp_ns);
  } catch (const std::invalid_argument& e) {
    // The EP keeps its state on refused input; the frame is counted and skipped.
    counters_.rejected.Increment("pipeline:ep_refused");
    spdlog::warn("EP refused frame {}: {}", frame.stamp_ns, e.what());
    return;
  }
  const auto& t = result->timings;
  stage_ms_->Add("ep.predict", t.predict_ms);
  stage_ms_->Add("ep.compare", t.compare_ms);
  stage_ms_->Add("ep.plan", t.plan_ms);
  stage_ms_->Add("ep.stereo", t.stereo_ms);
  stage_ms_->Add("ep.fuse", t.fuse_ms);
  stage_ms_->Add("ep.total", t.total_ms);
  if (const char* name = EventName(result->mode); *name) events_.Increment(name);
  if (result->from_earlier_view) events_.Increment("ep_predicted_from_earlier_view");
  if (result->mode != ep::FrameMode::kPredicted) full_refreshes_++;
  if (result->non_finite_rejected > 0) {
    events_.Increment("ep_non_finite_prediction_values", result->non_finite_rejected);
  }

  auto unexpected = std::make_shared<UnexpectedFrame>();
  unexpected->stamp_ns = frame.stamp_ns;
  unexpected->frame_index = snapshot.frame_index;
  unexpected->flagged_share = result->unexpected_share;
  std::function<Eigen::Vector3d(const Eigen::Vector3d&)> correct;
  if (active_models_ && active_models_->eye_hand()) {
    correct = [this](const Eigen::Vector3d& x) { return active_models_->CorrectVisionPoint(x); };
  }
  uint32_t id = 0;
  for (const auto& region : result->regions) {
    unexpected->regions.push_back(DescribeRegion(region, ++id, T_base_rect, T_odom_base, correct));
  }

  snapshot.disparity = result->disparity;
  snapshot.T_base_cam0 = T_base_rect;
  snapshot.T_odom_base = T_odom_base;
  snapshot.recomputed_share = result->recomputed_share;
  snapshot.grid_step = ep_params_.prediction.image_step;
  snapshot.ep = result;
  snapshot.unexpected = unexpected;
}

}  // namespace epmap::mapping
