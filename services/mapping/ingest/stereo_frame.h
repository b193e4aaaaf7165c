#pragma once
// A left/right pair as it leaves ingest: raw (unrectified) images sharing one stamp.

#include <chrono>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace epmap::mapping {

struct StereoFrame {
  uint64_t sequence = 0;  // order in which pairs were assembled
  int64_t stamp_ns = 0;
  cv::Mat left;
  cv::Mat right;
  std::string frame_id;                             // the left image's header.frame_id
  std::chrono::steady_clock::time_point assembled;  // for ingest-to-snapshot latency
};

}  // namespace epmap::mapping
