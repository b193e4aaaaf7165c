#pragma once
// Lets a stereo-extrinsics job borrow the raw (unrectified) stereo frames the pipeline sees.
// The pipeline offers every frame it takes from the queue; when no job listens that costs one
// atomic load. A listening job receives frames at least `min_interval_ns` apart in stamp (so
// that its frames show different eye configurations) into a small bounded buffer; the images
// are shared, not copied (neither side writes into them).

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "services/mapping/ingest/stereo_frame.h"

namespace epmap::mapping {

class RawFrameTap {
 public:
  class Subscription;

  // Pipeline side: cheap when nobody listens.
  void Offer(const StereoFrame& frame);

  // Job side: starts listening; frames arrive until the subscription is destroyed.
  std::unique_ptr<Subscription> Subscribe(int64_t min_interval_ns, size_t capacity = 4);
  uint64_t frames_offered() const { return offered_.load(); }

 private:
  struct Listener {
    std::mutex mutex;
    std::condition_variable arrived;
    std::deque<StereoFrame> frames;
    int64_t min_interval_ns = 0;
    size_t capacity = 4;
    std::optional<int64_t> last_stamp_ns;
    uint64_t skipped_full = 0;
  };
  void Remove(const Listener* listener);

  std::atomic<int> listeners_{0};
  std::atomic<uint64_t> offered_{0};
  std::mutex mutex_;
  std::vector<std::shared_ptr<Listener>> active_;
};

class RawFrameTap::Subscription {
 public:
  ~Subscription();
  // The next frame, waiting up to `timeout` in slices of at most 100 ms; `keep_waiting` is
  // asked between slices (cancellation). nullopt on timeout or when told to stop.
  std::optional<StereoFrame> Next(std::chrono::milliseconds timeout,
                                  const std::function<bool()>& keep_waiting);
  // Frames dropped because the job did not take them fast enough (they are not spaced out).
  uint64_t skipped() const;

 private:
  friend class RawFrameTap;
  Subscription(RawFrameTap& tap, std::shared_ptr<Listener> listener)
      : tap_(tap), listener_(std::move(listener)) {}
  RawFrameTap& tap_;
  std::shared_ptr<Listener> listener_;
};

}  // namespace epmap::mapping
