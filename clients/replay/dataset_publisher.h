#pragma once
// Publishes a dataset over DDS as live sensors would: stereo images with their CameraInfo,
// joint states and odometry, on ROS 2 topics, at the dataset's own rate or a requested one.

#include <cstdint>
#include <string>

#include "common/dataset/dataset.h"
#include "common/dds/topics.h"

namespace epmap::replay {

struct ReplayOptions {
  uint32_t domain = 0;
  double rate_hz = 0.0;  // 0: the dataset's own timing
  double wait_for_reader_s = 10.0;
  double linger_s = 0.5;      // keep the participant alive so the last samples arrive
  bool restamp = false;       // stamp with the wall clock instead of the dataset's stamps
  double loop_for_s = 0.0;    // > 0: replay the sequence again and again for this long (what
                              // is scheduled before it; the last pass may be partial; implies
                              // restamp, so stamps keep increasing)
  size_t preload_frames = 0;  // decode up to this many frames into memory before sending
                              // (keeps PNG decoding off the timed path of benchmarks)
  dds::TopicNames topics;
};

struct ReplayReport {
  size_t frames = 0;
  size_t loops = 0;
  size_t joint_states = 0;
  size_t odometry = 0;
  double seconds = 0.0;           // wall clock from the first send to the end of the last
  double last_scheduled_s = 0.0;  // when the last sent event was due (replay time): what the
                                  // schedule decided, independent of how loaded the host is
};

// Blocks until done. Throws std::runtime_error when no reader matches within the wait or an
// image cannot be read.
ReplayReport Replay(const dataset::Dataset& dataset, const ReplayOptions& options);

}  // namespace epmap::replay
