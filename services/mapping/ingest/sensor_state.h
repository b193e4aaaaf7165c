#pragma once
// The slow-changing and high-rate side inputs the pipeline needs for each frame: the latest
// CameraInfo of each camera, a short history of joint readings (interpolated to the image
// stamp) and of odometry. Written by DDS threads, read by the pipeline thread.

#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "common/dds/ros_conversions.h"
#include "services/mapping/ingest/counters.h"

namespace epmap::mapping {

class SensorState {
 public:
  explicit SensorState(CounterSet& rejected) : rejected_(rejected) {}

  void SetCameraInfo(int camera, const dds::CameraCalibration& calib);
  // Both cameras' calibrations and a version that changes whenever one of them changes.
  struct CameraInfos {
    std::optional<dds::CameraCalibration> left, right;
    uint64_t version = 0;
  };
  CameraInfos camera_infos() const;
  // Waits until both CameraInfos are known or the timeout passes.
  bool WaitForCameraInfos(std::chrono::nanoseconds timeout);

  // Adds a joint reading; refuses stamps that go backwards.
  void AddJoints(dds::JointReading reading);
  // Joint positions (by name, in `names` order) interpolated at stamp_ns. Waits up to `wait`
  // for a reading at or after the stamp. nullopt + *reason when none brackets the stamp
  // within max_gap_ns or a name is missing.
  std::optional<std::vector<double>> JointsAt(int64_t stamp_ns,
                                              const std::vector<std::string>& names,
                                              int64_t max_gap_ns, std::chrono::nanoseconds wait,
                                              std::string* reason);
  bool has_joints() const;
  std::vector<std::string> last_joint_names() const;

  void AddOdometry(const dds::PlanarOdometry& odom);
  // The frames rt/odom names (header.frame_id, child_frame_id), as its newest message had them.
  struct OdometryFrames {
    std::string frame_id, child_frame_id;
  };
  void SetOdometryFrames(const std::string& frame_id, const std::string& child_frame_id);
  OdometryFrames odometry_frames() const;
  std::optional<dds::PlanarOdometry> OdometryAt(int64_t stamp_ns, int64_t max_gap_ns,
                                                std::chrono::nanoseconds wait, std::string* reason);
  bool has_odometry() const;

  // Wakes waiters (shutdown).
  void Interrupt();

 private:
  static constexpr size_t kHistory = 512;
  CounterSet& rejected_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  CameraInfos infos_;
  std::deque<dds::JointReading> joints_;
  std::deque<dds::PlanarOdometry> odometry_;
  OdometryFrames odometry_frames_;
  bool interrupted_ = false;
};

}  // namespace epmap::mapping
