#include "services/mapping/ingest/dds_ingest.h"

#include <spdlog/spdlog.h>

namespace epmap::mapping {

namespace {
constexpr uint32_t kSmallMessageBytes = 1u << 20;  // CameraInfo, JointState, Odometry
}

DdsIngest::DdsIngest(const ServiceConfig& config, BoundedQueue<StereoFrame>& queue,
                     SensorState& sensors, IngestCounters& counters)
    : config_(config),
      queue_(queue),
      sensors_(sensors),
      counters_(counters),
      synchronizer_(config.pair_tolerance_ns, config.pair_timeout_ns, counters.rejected) {
  dds::TransportOptions transport;
  transport.shared_memory = config.shared_memory_transport;
  participant_ = std::make_unique<dds::Participant>(config.domain, "epmapd", transport);
  const auto& t = config.topics;

  left_image_ = std::make_unique<ImageReader>(
      *participant_, t.left_image,
      [this](sensor_msgs::msg::Image&& m) {
        OnImage(StereoSynchronizer::Side::kLeft, std::move(m));
      },
      config.max_image_bytes);
  right_image_ = std::make_unique<ImageReader>(
      *participant_, t.right_image,
      [this](sensor_msgs::msg::Image&& m) {
        OnImage(StereoSynchronizer::Side::kRight, std::move(m));
      },
      config.max_image_bytes);

  const auto on_info = [this](int camera, const char* topic) {
    return [this, camera, topic](sensor_msgs::msg::CameraInfo&& msg) {
      std::string reason;
      const auto calib = dds::FromCameraInfo(msg, &reason);
      if (!calib) {
        counters_.rejected.Increment(std::string(topic) + ":" + reason);
        return;
      }
      sensors_.SetCameraInfo(camera, *calib);
    };
  };
  left_info_ = std::make_unique<InfoReader>(*participant_, t.left_info,
                                            on_info(0, "left_camera_info"), kSmallMessageBytes);
  right_info_ = std::make_unique<InfoReader>(*participant_, t.right_info,
                                             on_info(1, "right_camera_info"), kSmallMessageBytes);

  joints_ = std::make_unique<JointReader>(
      *participant_, t.joints,
      [this](sensor_msgs::msg::JointState&& msg) {
        std::string reason;
        auto reading = dds::FromJointState(msg, &reason);
        if (!reading) {
          counters_.rejected.Increment("joint_states:" + reason);
          return;
        }
        sensors_.AddJoints(std::move(*reading));
      },
      kSmallMessageBytes, 50);

  odom_ = std::make_unique<OdomReader>(
      *participant_, t.odom,
      [this](nav_msgs::msg::Odometry&& msg) {
        std::string reason;
        const auto odom = dds::FromOdometry(msg, &reason);
        if (!odom) {
          counters_.rejected.Increment("odometry:" + reason);
          return;
        }
        sensors_.SetOdometryFrames(msg.header().frame_id(), msg.child_frame_id());
        sensors_.AddOdometry(*odom);
      },
      kSmallMessageBytes, 50);

  eye_hand_ = std::make_unique<EyeHandReader>(
      *participant_, t.eye_hand_samples,
      [this](epmap_msgs::msg::EyeHandSamples&& msg) {
        std::lock_guard lock(eye_hand_mutex_);
        if (!eye_hand_callback_) {
          counters_.rejected.Increment("eye_hand_samples:calibration_disabled");
          return;
        }
        eye_hand_callback_(std::move(msg));
      },
      16u << 20, 10);
}

DdsIngest::~DdsIngest() {
  // Readers first (their listeners use this object), then the participant.
  eye_hand_.reset();
  odom_.reset();
  joints_.reset();
  right_info_.reset();
  left_info_.reset();
  right_image_.reset();
  left_image_.reset();
  participant_.reset();
}

void DdsIngest::SetEyeHandCallback(EyeHandCallback callback) {
  std::lock_guard lock(eye_hand_mutex_);
  eye_hand_callback_ = std::move(callback);
}

void DdsIngest::OnImage(StereoSynchronizer::Side side, sensor_msgs::msg::Image&& msg) {
  const char* topic = side == StereoSynchronizer::Side::kLeft ? "left_image" : "right_image";
  std::string reason;
  cv::Mat image = dds::ImageToMat(msg, &reason);
  if (image.empty()) {
    counters_.rejected.Increment(std::string(topic) + ":" + reason);
    return;
  }
  const int64_t stamp = dds::ToNanoseconds(msg.header().stamp());
  auto frame = synchronizer_.Add(side, stamp, std::move(image), msg.header().frame_id());
  if (!frame) return;
  counters_.frames_assembled++;
  if (const size_t dropped = queue_.Push(std::move(*frame)); dropped > 0) {
    counters_.queue_drops.Increment("queue_full_dropped_oldest", dropped);
  }
}

std::vector<DdsIngest::TopicCounters> DdsIngest::CollectTopicCounters() const {
  std::vector<TopicCounters> out;
  // `name` is the short name used in rejection reasons ("left_image:size_mismatch").
  const auto add = [&](const char* name, const std::string& topic, const dds::ReaderCounters& c) {
    out.push_back({topic, c.received.load(), c.lost.load()});
    // Transport-level refusals are counted with the content refusals.
    const std::string prefix = std::string(name) + ":";
    if (c.oversized) counters_.rejected.Set(prefix + "oversized", c.oversized.load());
    if (c.malformed) counters_.rejected.Set(prefix + "malformed", c.malformed.load());
    if (c.rejected) counters_.rejected.Set(prefix + "rejected_by_dds", c.rejected.load());
  };
  add("left_image", config_.topics.left_image, left_image_->counters());
  add("right_image", config_.topics.right_image, right_image_->counters());
  add("left_camera_info", config_.topics.left_info, left_info_->counters());
  add("right_camera_info", config_.topics.right_info, right_info_->counters());
  add("joint_states", config_.topics.joints, joints_->counters());
  add("odometry", config_.topics.odom, odom_->counters());
  add("eye_hand_samples", config_.topics.eye_hand_samples, eye_hand_->counters());
  return out;
}

int DdsIngest::matched_image_writers() const {
  return std::min(left_image_->MatchedWriters(), right_image_->MatchedWriters());
}

}  // namespace epmap::mapping
