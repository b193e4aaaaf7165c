#include "services/mapping/ros_output/ros_perception_publisher.h"

#include <epmap_dds/DisparityImagePubSubTypes.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <spdlog/spdlog.h>

#include <opencv2/core.hpp>
#include <optional>

#include "common/dds/endpoints.h"
#include "common/dds/ros_conversions.h"

namespace epmap::mapping {

void ToRosDisparity(const MapSnapshot& snapshot, stereo_msgs::msg::DisparityImage* out) {
  const cv::Mat& d = snapshot.disparity;
  if (d.empty() || d.type() != CV_32FC1) {
    throw std::invalid_argument("ToRosDisparity: the snapshot has no CV_32FC1 disparity");
  }
  const std::string frame = snapshot.camera_frame();
  const float invalid = static_cast<float>(snapshot.min_disparity) - 1.0f;
  out->header().stamp(dds::FromNanoseconds(snapshot.stamp_ns));
  out->header().frame_id(frame);
  auto& image = out->image();
  image.header(out->header());
  image.height(static_cast<uint32_t>(d.rows));
  image.width(static_cast<uint32_t>(d.cols));
  image.encoding("32FC1");
  image.is_bigendian(0);
  image.step(static_cast<uint32_t>(d.cols * sizeof(float)));
  auto& data = image.data();
  data.resize(static_cast<size_t>(d.rows) * d.cols * sizeof(float));
  // Written in place into the message's buffer (heap memory: aligned for floats).
  cv::Mat in_message(d.rows, d.cols, CV_32FC1, data.data());
  d.copyTo(in_message);
  cv::patchNaNs(in_message, invalid);
  out->f(static_cast<float>(snapshot.camera.fx));
  out->t(static_cast<float>(snapshot.camera.baseline_m));
  out->valid_window().x_offset(0);
  out->valid_window().y_offset(0);
  out->valid_window().width(static_cast<uint32_t>(d.cols));
  out->valid_window().height(static_cast<uint32_t>(d.rows));
  out->valid_window().do_rectify(false);
  out->min_disparity(static_cast<float>(snapshot.min_disparity));
  out->max_disparity(static_cast<float>(snapshot.min_disparity + snapshot.num_disparities - 1));
  out->delta_d(1.0f / 16.0f);
}

struct RosPerceptionPublisher::Writers {
  std::optional<
      dds::Writer<stereo_msgs::msg::DisparityImage, stereo_msgs::msg::DisparityImagePubSubType>>
      disparity;
  std::optional<dds::Writer<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType>> mask;
};

RosPerceptionPublisher::RosPerceptionPublisher(const ServiceConfig& config,
                                               dds::Participant& participant,
                                               const SnapshotStore& snapshots, CounterSet& events)
    : config_(config), snapshots_(snapshots), events_(events), writers_(new Writers) {
  // Depth 1: a reader that falls behind gets the newest map, not a queue of old ones.
  if (!config_.topics.disparity.empty()) {
    writers_->disparity.emplace(participant, dds::RosTopic(config_.topics.disparity), 1);
  }
  if (!config_.topics.unexpected_mask.empty() && config_.ep.enabled) {
    writers_->mask.emplace(participant, dds::RosTopic(config_.topics.unexpected_mask), 1);
  }
  if (writers_->disparity || writers_->mask) thread_ = std::thread([this] { Run(); });
}

RosPerceptionPublisher::~RosPerceptionPublisher() {
  Stop();
}

void RosPerceptionPublisher::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void RosPerceptionPublisher::Run() {
  uint64_t seen_frame = 0;
  while (!stop_) {
    const auto snapshot = snapshots_.WaitNewer(seen_frame, std::chrono::milliseconds(200));
    if (!snapshot || snapshot->frame_index <= seen_frame) {
      // Nothing newer (or the store closed at shutdown): do not spin.
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    seen_frame = snapshot->frame_index;
    Publish(*snapshot);
  }
}

void RosPerceptionPublisher::Publish(const MapSnapshot& snapshot) {
  if (writers_->disparity && writers_->disparity->MatchedReaders() > 0 &&
      !snapshot.disparity.empty()) {
    stereo_msgs::msg::DisparityImage msg;
    ToRosDisparity(snapshot, &msg);
    if (writers_->disparity->Write(msg)) {
      events_.Increment("ros_disparity_published");
    } else {
      spdlog::warn("{}: frame {} could not be written", config_.topics.disparity,
                   snapshot.frame_index);
    }
  }
  if (writers_->mask && writers_->mask->MatchedReaders() > 0 && snapshot.ep &&
      !snapshot.ep->unexpected.empty()) {
    sensor_msgs::msg::Image msg;
    dds::MatToImage(snapshot.ep->unexpected, snapshot.stamp_ns, snapshot.camera_frame(), &msg);
    if (writers_->mask->Write(msg)) {
      events_.Increment("ros_unexpected_mask_published");
    } else {
      spdlog::warn("{}: frame {} could not be written", config_.topics.unexpected_mask,
                   snapshot.frame_index);
    }
  }
}

}  // namespace epmap::mapping
