#include "services/mapping/pipeline/unexpected_events.h"

#include <algorithm>

namespace epmap::mapping {

UnexpectedRegionInfo DescribeRegion(
    const ep::Region& region, uint32_t id, const Eigen::Isometry3d& T_base_cam0,
    const std::optional<Eigen::Isometry3d>& T_odom_base,
    const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& correct) {
  UnexpectedRegionInfo info;
  info.id = id;
  info.box = region.box;
  info.area_px = region.area_px;
  info.mean_disparity_px = region.mean_disparity_px;
  info.has_centroid = region.has_centroid;
  info.centroid_camera = region.centroid_cam0;
  info.centroid_base = T_base_cam0 * region.centroid_cam0;
  if (region.has_centroid && correct) {
    info.centroid_base = correct(info.centroid_base);
    info.base_corrected = true;
  }
  if (T_odom_base) info.centroid_odom = *T_odom_base * info.centroid_base;
  return info;
}

std::shared_ptr<const UnexpectedFrame> UnexpectedEventHub::Subscription::Next(
    std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  ready_.wait_for(lock, timeout, [&] { return closed_ || !queue_.empty(); });
  if (queue_.empty()) return nullptr;
  auto frame = std::move(queue_.front());
  queue_.pop_front();
  return frame;
}

uint64_t UnexpectedEventHub::Subscription::dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}

std::shared_ptr<UnexpectedEventHub::Subscription> UnexpectedEventHub::Subscribe(size_t capacity) {
  std::shared_ptr<Subscription> s(new Subscription(std::max<size_t>(capacity, 1)));
  std::lock_guard lock(mutex_);
  if (closed_) s->closed_ = true;
  subscriptions_.push_back(s);
  return s;
}

void UnexpectedEventHub::Unsubscribe(const std::shared_ptr<Subscription>& subscription) {
  std::lock_guard lock(mutex_);
  subscriptions_.erase(std::remove(subscriptions_.begin(), subscriptions_.end(), subscription),
                       subscriptions_.end());
}

void UnexpectedEventHub::Publish(const std::shared_ptr<const UnexpectedFrame>& frame) {
  std::lock_guard lock(mutex_);
  for (const auto& s : subscriptions_) {
    {
      std::lock_guard sub_lock(s->mutex_);
      if (s->queue_.size() >= s->capacity_) {
        s->queue_.pop_front();
        s->dropped_++;
      }
      s->queue_.push_back(frame);
    }
    s->ready_.notify_one();
  }
}

void UnexpectedEventHub::Close() {
  std::lock_guard lock(mutex_);
  closed_ = true;
  for (const auto& s : subscriptions_) {
    {
      std::lock_guard sub_lock(s->mutex_);
      s->closed_ = true;
    }
    s->ready_.notify_all();
  }
}

size_t UnexpectedEventHub::subscribers() const {
  std::lock_guard lock(mutex_);
  return subscriptions_.size();
}

}  // namespace epmap::mapping
