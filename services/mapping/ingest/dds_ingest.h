#pragma once
// DDS side of epmapd: readers on the ROS 2 topics (BEST_EFFORT, VOLATILE), validation of
// every sample, left/right pairing, and the hand-over to the pipeline's bounded queue.
// Listener callbacks only copy, check and enqueue: they never block.

#include <epmap_dds/CameraInfoPubSubTypes.h>
#include <epmap_dds/EyeHandSamplesPubSubTypes.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <epmap_dds/JointStatePubSubTypes.h>
#include <epmap_dds/OdometryPubSubTypes.h>

#include <atomic>
#include <functional>
#include <memory>

#include "common/dds/endpoints.h"
#include "common/dds/participant.h"
#include "services/mapping/config/service_config.h"
#include "services/mapping/ingest/bounded_queue.h"
#include "services/mapping/ingest/counters.h"
#include "services/mapping/ingest/sensor_state.h"
#include "services/mapping/ingest/stereo_synchronizer.h"

namespace epmap::mapping {

struct IngestCounters {
  CounterSet rejected;  // "<topic>:<reason>" for every refused sample or pair
  // "maps:<reason>" for every key frame the maps of mobile-base mode refused: the frame itself
  // was processed (its disparity is served), so it is not a rejected frame.
  CounterSet key_frames_refused;
  CounterSet queue_drops;  // "<reason>" for every frame dropped between ingest and pipeline
  std::atomic<uint64_t> frames_assembled{0};
};

class DdsIngest {
 public:
  using EyeHandCallback = std::function<void(epmap_msgs::msg::EyeHandSamples&&)>;

  DdsIngest(const ServiceConfig& config, BoundedQueue<StereoFrame>& queue, SensorState& sensors,
            IngestCounters& counters);
  ~DdsIngest();

  // Eye-hand samples arriving on DDS go to this callback (set before samples flow).
  void SetEyeHandCallback(EyeHandCallback callback);

  struct TopicCounters {
    std::string topic;
    uint64_t received = 0;
    uint64_t lost = 0;
  };
  // Per-topic receive counts; also folds the readers' transport refusals (oversized,
  // malformed) into counters.rejected.
  std::vector<TopicCounters> CollectTopicCounters() const;
  int matched_image_writers() const;
  // The service's one DDS participant (what epmapd publishes goes through it too).
  dds::Participant& participant() { return *participant_; }

 private:
  void OnImage(StereoSynchronizer::Side side, sensor_msgs::msg::Image&& msg);

  const ServiceConfig config_;
  BoundedQueue<StereoFrame>& queue_;
  SensorState& sensors_;
  IngestCounters& counters_;
  StereoSynchronizer synchronizer_;
  std::mutex eye_hand_mutex_;
  EyeHandCallback eye_hand_callback_;

  std::unique_ptr<dds::Participant> participant_;
  using ImageReader = dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType>;
  using InfoReader =
      dds::Reader<sensor_msgs::msg::CameraInfo, sensor_msgs::msg::CameraInfoPubSubType>;
  using JointReader =
      dds::Reader<sensor_msgs::msg::JointState, sensor_msgs::msg::JointStatePubSubType>;
  using OdomReader = dds::Reader<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType>;
  using EyeHandReader =
      dds::Reader<epmap_msgs::msg::EyeHandSamples, epmap_msgs::msg::EyeHandSamplesPubSubType>;
  std::unique_ptr<ImageReader> left_image_, right_image_;
  std::unique_ptr<InfoReader> left_info_, right_info_;
  std::unique_ptr<JointReader> joints_;
  std::unique_ptr<OdomReader> odom_;
  std::unique_ptr<EyeHandReader> eye_hand_;
};

}  // namespace epmap::mapping
