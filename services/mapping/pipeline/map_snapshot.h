#pragma once
// What the pipeline knows after one frame, published as an immutable snapshot: the API reads
// the newest one without ever blocking the pipeline (it swaps a shared_ptr).

#include <Eigen/Geometry>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "perception/ep/expected_perception.h"
#include "perception/mobile_mapping/mobile_mapper.h"
#include "perception/stereo/rectification.h"
#include "services/mapping/pipeline/unexpected_events.h"

namespace epmap::mapping {

// Where the camera was at one frame: on the base (the chain), and where the base was in the
// odometry frame when odometry drives the pose source (a mobile base). The world stands still
// in the odometry frame, so that is the frame the EP predicts in.
struct FramePose {
  Eigen::Isometry3d T_base_cam0 = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> T_odom_base;
};

struct MapSnapshot {
  uint64_t frame_index = 0;  // 1 for the first processed frame
  int64_t stamp_ns = 0;
  std::string frame_id;  // the left image's header.frame_id: the camera the disparity is in
  stereo::RectifiedGeometry camera;
  int min_disparity = 0;
  int num_disparities = 0;
  cv::Mat disparity;                             // CV_32FC1 px, NaN unknown (rectified cam0)
  cv::Mat left_rectified;                        // the image the disparity belongs to
  std::optional<Eigen::Isometry3d> T_base_cam0;  // when a kinematic pose is known
  std::optional<Eigen::Isometry3d> T_odom_base;  // mobile base: from odometry
  // The frames of those poses: the URDF's root link ("base" without a URDF) and the left
  // camera's optical link (robot.left_camera_link), as a tf tree built from the URDF names them.
  std::string base_frame = "base";
  std::string camera_link = "cam0_optical";
  double recomputed_share = 1.0;  // share of pixels whose disparity was computed this frame
  double valid_share = 0.0;       // share of pixels with a finite disparity
  // The expected-perception result of this frame (null when EP is disabled): predicted image,
  // E, C, A on the comparison grid, the unexpected and recompute masks.
  std::shared_ptr<const ep::EpResult> ep;
  int grid_step = 1;  // the comparison grid's step (ep->error etc. are size / grid_step)
  // What moved on its own (null when EP is disabled), with centroids in the base frame as the
  // active eye-hand model corrects them (and in the odometry frame on a mobile base).
  std::shared_ptr<const UnexpectedFrame> unexpected;
  // Mobile-base mode: the perceptual map, occupancy grid and poses after the newest key frame
  // (null before the first key frame, or when not in mobile-base mode). Shared between
  // snapshots until the next key frame changes the maps.
  std::shared_ptr<const mobile_mapping::MapsSnapshot> maps;

  // The camera frame of the images and the disparity: the left image's frame_id, or the left
  // camera's link when the publisher sent none.
  std::string camera_frame() const { return frame_id.empty() ? camera_link : frame_id; }
};

// Holds the newest snapshot; readers may wait for one newer than a stamp or frame.
class SnapshotStore {
 public:
  void Publish(std::shared_ptr<const MapSnapshot> snapshot) {
    {
      std::lock_guard lock(mutex_);
      latest_ = std::move(snapshot);
    }
    changed_.notify_all();
  }

  std::shared_ptr<const MapSnapshot> Latest() const {
    std::lock_guard lock(mutex_);
    return latest_;
  }

  // Waits up to `timeout` for a snapshot whose frame_index is above `after_frame`; returns the
  // newest one either way (possibly null).
  std::shared_ptr<const MapSnapshot> WaitNewer(uint64_t after_frame,
                                               std::chrono::milliseconds timeout) const {
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, timeout,
                      [&] { return closed_ || (latest_ && latest_->frame_index > after_frame); });
    return latest_;
  }

  void Close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    changed_.notify_all();
  }

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::shared_ptr<const MapSnapshot> latest_;
  bool closed_ = false;
};

}  // namespace epmap::mapping
