#pragma once
// What moved on its own in one frame (paper 000: the regions the visual comparator flags, the
// robot's detector of independently moving things), and the hub that hands each frame's
// regions to every live WatchUnexpected stream. Each subscriber has a bounded queue: a slow
// client loses its oldest events (counted), never the pipeline's time.

#include <Eigen/Geometry>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "perception/ep/comparator/regions.h"

namespace epmap::mapping {

struct UnexpectedRegionInfo {
  uint32_t id = 0;  // 1.. in the frame, largest first
  cv::Rect box;     // rectified cam0 image, px
  int area_px = 0;
  double mean_disparity_px = 0;  // NaN if no pixel had a disparity
  bool has_centroid = false;
  Eigen::Vector3d centroid_camera = Eigen::Vector3d::Zero();  // cam0 (rectified) frame, m
  Eigen::Vector3d centroid_base = Eigen::Vector3d::Zero();    // base frame, m
  bool base_corrected = false;  // the active eye-hand model was applied to centroid_base
  // Mobile base: centroid_base in the odometry frame at the frame's stamp.
  std::optional<Eigen::Vector3d> centroid_odom;
};

// One EP region as the service reports it. T_base_cam0: the (rectified) camera on the base, from
// the chain; T_odom_base: the base in the odometry frame on a mobile base (the EP itself works in
// that frame there, so its own "base" centroid is not the base's). `correct`, when set, is the
// active eye-hand model (paper 001: stereo's points made consistent with the kinematics), applied
// to the base-frame centroid before it is carried into the odometry frame.
UnexpectedRegionInfo DescribeRegion(
    const ep::Region& region, uint32_t id, const Eigen::Isometry3d& T_base_cam0,
    const std::optional<Eigen::Isometry3d>& T_odom_base,
    const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& correct = nullptr);

struct UnexpectedFrame {
  int64_t stamp_ns = 0;
  uint64_t frame_index = 0;
  double flagged_share = 0;  // share of the image flagged unexpected
  std::vector<UnexpectedRegionInfo> regions;
};

class UnexpectedEventHub {
 public:
  class Subscription {
   public:
    // The next frame, waiting up to `timeout`; null on timeout or once the hub is closed.
    std::shared_ptr<const UnexpectedFrame> Next(std::chrono::milliseconds timeout);
    uint64_t dropped() const;

   private:
    friend class UnexpectedEventHub;
    explicit Subscription(size_t capacity) : capacity_(capacity) {}
    const size_t capacity_;
    mutable std::mutex mutex_;
    std::condition_variable ready_;
    std::deque<std::shared_ptr<const UnexpectedFrame>> queue_;
    uint64_t dropped_ = 0;
    bool closed_ = false;
  };

  std::shared_ptr<Subscription> Subscribe(size_t capacity = 64);
  void Unsubscribe(const std::shared_ptr<Subscription>& subscription);
  void Publish(const std::shared_ptr<const UnexpectedFrame>& frame);
  void Close();
  size_t subscribers() const;

 private:
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<Subscription>> subscriptions_;
  bool closed_ = false;
};

}  // namespace epmap::mapping
