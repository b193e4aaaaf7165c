#pragma once
// The EP's output for ROS 2 nodes on DDS, beside the gRPC API, in every mode: the disparity map
// of each processed frame as stereo_msgs/DisparityImage (what stereo_image_proc publishes, so
// point_cloud_node, disparity_view and RViz take it unchanged) and the unexpected-motion mask
// (paper 000's detector of things that move on their own) as a mono8 sensor_msgs/Image, 255
// where something moved. A thread of its own follows the snapshots (the newest one when it
// falls behind; the pipeline never waits for DDS), and converts a frame only while a reader is
// matched: with nobody listening a 640x480 map costs nothing.

#include <atomic>
#include <memory>
#include <thread>

#include "common/dds/participant.h"
#include "services/mapping/config/service_config.h"
#include "services/mapping/ingest/counters.h"
#include "services/mapping/pipeline/map_snapshot.h"

namespace stereo_msgs::msg {
class DisparityImage;
}
namespace sensor_msgs::msg {
class Image;
}

namespace epmap::mapping {

// The snapshot's disparity in ROS's convention: 32FC1, unknown pixels (NaN) written as
// min_disparity - 1 ("any disparity less than min_disparity is invalid"); f and t from the
// rectified geometry (Z = f t / d); the whole image as the valid window (the EP predicts into
// SGBM's blind margin); max_disparity = min + num - 1; delta_d = 1/16 (SGBM's sub-pixel step).
void ToRosDisparity(const MapSnapshot& snapshot, stereo_msgs::msg::DisparityImage* out);

class RosPerceptionPublisher {
 public:
  // Publishes on config.topics.disparity / .unexpected_mask (an empty name: that one is off)
  // through participant, counting in events: ros_disparity_published,
  // ros_unexpected_mask_published. The mask goes out only when the EP is enabled.
  RosPerceptionPublisher(const ServiceConfig& config, dds::Participant& participant,
                         const SnapshotStore& snapshots, CounterSet& events);
  ~RosPerceptionPublisher();  // stops the thread
  RosPerceptionPublisher(const RosPerceptionPublisher&) = delete;
  RosPerceptionPublisher& operator=(const RosPerceptionPublisher&) = delete;

  void Stop();

 private:
  struct Writers;
  void Run();
  void Publish(const MapSnapshot& snapshot);

  const ServiceConfig config_;
  const SnapshotStore& snapshots_;
  CounterSet& events_;
  std::unique_ptr<Writers> writers_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace epmap::mapping
