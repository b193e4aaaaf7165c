#pragma once
// Pairs left and right images by stamp. Each camera's stamps must increase; an image whose
// partner does not arrive within the timeout is dropped; a pair whose images differ in size or
// type is rejected. Thread-safe: left and right arrive on different DDS threads.

#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "services/mapping/ingest/counters.h"
#include "services/mapping/ingest/stereo_frame.h"

namespace epmap::mapping {

class StereoSynchronizer {
 public:
  StereoSynchronizer(int64_t tolerance_ns, int64_t timeout_ns, CounterSet& rejected);

  enum class Side { kLeft, kRight };
  // Adds one validated image; returns a complete pair when this image finished one. frame_id:
  // the image header's (the pair carries the left one's, which its disparity is in).
  std::optional<StereoFrame> Add(Side side, int64_t stamp_ns, cv::Mat image,
                                 std::string frame_id = {});

 private:
  void ExpireOlderThan(int64_t stamp_ns);

  const int64_t tolerance_ns_;
  const int64_t timeout_ns_;
  CounterSet& rejected_;
  std::mutex mutex_;
  struct Pending {
    cv::Mat image;
    std::string frame_id;
  };
  std::map<int64_t, Pending> pending_[2];
  int64_t last_stamp_[2] = {INT64_MIN, INT64_MIN};
  int64_t last_paired_stamp_ = INT64_MIN;
  uint64_t sequence_ = 0;
};

}  // namespace epmap::mapping
