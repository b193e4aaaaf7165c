#pragma once
// Sends a scenario over DDS in real time on the service's ROS 2 topics (common/dds/topics.h),
// as a calibrated ROS 2 stereo driver plus joint-state and odometry publishers would:
//   left/right image_raw (bgr8 or mono8), left/right camera_info with every frame,
//   joint_states at the image stamps, odom (building).
// The eye-hand scenario has no image stream: its samples go out on the EyeHandSamples topic,
// one message per ellipsoidal path.

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "clients/sim/scenario.h"
#include "common/dds/topics.h"

namespace epmap::sim {

struct PublishOptions {
  uint32_t domain_id = 0;
  double rate_hz = 0;                // 0 = the scenario's own rate
  int max_frames = 0;                // stop after this many stereo frames (0: all there are)
  bool as_fast_as_possible = false;  // ignore the rate (benchmarks): send as rendering allows
  dds::TopicNames topics;
  // Before sending, wait until a reader matched each image writer (or the sample writer), at
  // most this long (then go on with a warning), and then a grace period for the rest of
  // discovery so that no frame is lost.
  std::chrono::milliseconds wait_for_readers{10'000};
  std::chrono::milliseconds grace{500};
  int render_threads = 2;                       // frames rendered ahead in parallel
  std::function<bool()> stop_requested;         // polled between frames (e.g. SIGINT)
  std::function<void(const std::string&)> log;  // warnings and a summary
};

struct PublishReport {
  int frames_sent = 0;     // stereo frames (or eye-hand paths) written
  double seconds = 0;      // from the first frame sent to the last
  int late_frames = 0;     // frames sent more than 5 ms after their scheduled time
  double max_late_ms = 0;  // the latest of them
  bool readers_matched = false;
  int64_t first_stamp_ns = 0;  // wall-clock stamp of frame 0
};

// Stamps are the wall clock when sending starts plus the scenario's frame times. Renders
// ahead on a second thread. Throws std::runtime_error if the DDS entities cannot be created.
PublishReport Publish(const Scenario& scenario, const PublishOptions& options);

}  // namespace epmap::sim
