#include "services/mapping/calibration/frame_tap.h"

#include <algorithm>

namespace epmap::mapping {

void RawFrameTap::Offer(const StereoFrame& frame) {
  offered_++;
  if (listeners_.load(std::memory_order_acquire) == 0) return;
  std::vector<std::shared_ptr<Listener>> listeners;
  {
    std::lock_guard lock(mutex_);
    listeners = active_;
  }
  for (const auto& l : listeners) {
    {
      std::lock_guard lock(l->mutex);
      if (l->last_stamp_ns && frame.stamp_ns - *l->last_stamp_ns < l->min_interval_ns) continue;
      if (l->frames.size() >= l->capacity) {
        ++l->skipped_full;
        continue;
      }
      l->frames.push_back(frame);
      l->last_stamp_ns = frame.stamp_ns;
    }
    l->arrived.notify_all();
  }
}

std::unique_ptr<RawFrameTap::Subscription> RawFrameTap::Subscribe(int64_t min_interval_ns,
                                                                  size_t capacity) {
  auto listener = std::make_shared<Listener>();
  listener->min_interval_ns = min_interval_ns;
  listener->capacity = std::max<size_t>(1, capacity);
  {
    std::lock_guard lock(mutex_);
    active_.push_back(listener);
  }
  listeners_++;
  return std::unique_ptr<Subscription>(new Subscription(*this, std::move(listener)));
}

void RawFrameTap::Remove(const Listener* listener) {
  std::lock_guard lock(mutex_);
  const auto it = std::find_if(active_.begin(), active_.end(),
                               [&](const auto& l) { return l.get() == listener; });
  if (it != active_.end()) {
    active_.erase(it);
    listeners_--;
  }
}

RawFrameTap::Subscription::~Subscription() {
  tap_.Remove(listener_.get());
}

std::optional<StereoFrame> RawFrameTap::Subscription::Next(
    std::chrono::milliseconds timeout, const std::function<bool()>& keep_waiting) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::unique_lock lock(listener_->mutex);
  while (listener_->frames.empty()) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) return std::nullopt;
    listener_->arrived.wait_until(lock, std::min(deadline, now + std::chrono::milliseconds(100)));
    if (listener_->frames.empty() && keep_waiting && !keep_waiting()) return std::nullopt;
  }
  StereoFrame frame = std::move(listener_->frames.front());
  listener_->frames.pop_front();
  return frame;
}

uint64_t RawFrameTap::Subscription::skipped() const {
  std::lock_guard lock(listener_->mutex);
  return listener_->skipped_full;
}

}  // namespace epmap::mapping
