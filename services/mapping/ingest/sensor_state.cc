#include "services/mapping/ingest/sensor_state.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace epmap::mapping {

namespace {
bool SameCalibration(const dds::CameraCalibration& a, const dds::CameraCalibration& b) {
  return a.width == b.width && a.height == b.height && a.d == b.d && a.k == b.k && a.r == b.r &&
         a.p == b.p && a.distortion_model == b.distortion_model;
}
}  // namespace

void SensorState::SetCameraInfo(int camera, const dds::CameraCalibration& calib) {
  {
    std::lock_guard lock(mutex_);
    auto& slot = camera == 0 ? infos_.left : infos_.right;
    if (slot && SameCalibration(*slot, calib)) return;
    slot = calib;
    ++infos_.version;
  }
  changed_.notify_all();
}

SensorState::CameraInfos SensorState::camera_infos() const {
  std::lock_guard lock(mutex_);
  return infos_;
}

bool SensorState::WaitForCameraInfos(std::chrono::nanoseconds timeout) {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout,
                           [&] {
                             return interrupted_ ||
                                    (infos_.left.has_value() && infos_.right.has_value());
                           }) &&
         infos_.left && infos_.right;
}

void SensorState::AddJoints(dds::JointReading reading) {
  {
    std::lock_guard lock(mutex_);
    if (!joints_.empty() && reading.stamp_ns <= joints_.back().stamp_ns) {
      rejected_.Increment("joint_states:stamp_not_increasing");
      return;
    }
    joints_.push_back(std::move(reading));
    if (joints_.size() > kHistory) joints_.pop_front();
  }
  changed_.notify_all();
}

bool SensorState::has_joints() const {
  std::lock_guard lock(mutex_);
  return !joints_.empty();
}

std::vector<std::string> SensorState::last_joint_names() const {
  std::lock_guard lock(mutex_);
  return joints_.empty() ? std::vector<std::string>{} : joints_.back().names;
}

std::optional<std::vector<double>> SensorState::JointsAt(int64_t stamp_ns,
                                                         const std::vector<std::string>& names,
                                                         int64_t max_gap_ns,
                                                         std::chrono::nanoseconds wait,
                                                         std::string* reason) {
  std::unique_lock lock(mutex_);
  // Encoders usually run faster than cameras; give a reading after the image a moment to come.
  changed_.wait_for(lock, wait, [&] {
    return interrupted_ || (!joints_.empty() && joints_.back().stamp_ns >= stamp_ns);
  });
  if (joints_.empty()) {
    *reason = "no_joint_states";
    return std::nullopt;
  }
  const auto after =
      std::lower_bound(joints_.begin(), joints_.end(), stamp_ns,
                       [](const dds::JointReading& r, int64_t t) { return r.stamp_ns < t; });
  const dds::JointReading* lo = nullptr;
  const dds::JointReading* hi = nullptr;
  if (after == joints_.end()) {
    lo = hi = &joints_.back();
  } else if (after->stamp_ns == stamp_ns || after == joints_.begin()) {
    lo = hi = &*after;
  } else {
    lo = &*std::prev(after);
    hi = &*after;
  }
  if (std::llabs(lo->stamp_ns - stamp_ns) > max_gap_ns &&
      std::llabs(hi->stamp_ns - stamp_ns) > max_gap_ns) {
    *reason = "joint_states_too_far_from_image";
    return std::nullopt;
  }
  const double w = hi->stamp_ns == lo->stamp_ns
                       ? 0.0
                       : static_cast<double>(stamp_ns - lo->stamp_ns) /
                             static_cast<double>(hi->stamp_ns - lo->stamp_ns);
  std::vector<double> out;
  out.reserve(names.size());
  for (const auto& name : names) {
    const auto find = [&](const dds::JointReading& r) -> std::optional<double> {
      for (size_t i = 0; i < r.names.size(); ++i) {
        if (r.names[i] == name) return r.positions[i];
      }
      return std::nullopt;
    };
    const auto a = find(*lo);
    const auto b = find(*hi);
    if (!a || !b) {
      *reason = "joint_states_missing_joint";
      return std::nullopt;
    }
    out.push_back((1.0 - w) * *a + w * *b);
  }
  return out;
}

void SensorState::AddOdometry(const dds::PlanarOdometry& odom) {
  {
    std::lock_guard lock(mutex_);
    if (!odometry_.empty() && odom.stamp_ns <= odometry_.back().stamp_ns) {
      rejected_.Increment("odometry:stamp_not_increasing");
      return;
    }
    odometry_.push_back(odom);
    if (odometry_.size() > kHistory) odometry_.pop_front();
  }
  changed_.notify_all();
}

void SensorState::SetOdometryFrames(const std::string& frame_id,
                                    const std::string& child_frame_id) {
  std::lock_guard lock(mutex_);
  // Compared first: the names rarely change, and assigning would copy them at the odometry rate.
  if (odometry_frames_.frame_id != frame_id) odometry_frames_.frame_id = frame_id;
  if (odometry_frames_.child_frame_id != child_frame_id) {
    odometry_frames_.child_frame_id = child_frame_id;
  }
}

SensorState::OdometryFrames SensorState::odometry_frames() const {
  std::lock_guard lock(mutex_);
  return odometry_frames_;
}

bool SensorState::has_odometry() const {
  std::lock_guard lock(mutex_);
  return !odometry_.empty();
}

std::optional<dds::PlanarOdometry> SensorState::OdometryAt(int64_t stamp_ns, int64_t max_gap_ns,
                                                           std::chrono::nanoseconds wait,
                                                           std::string* reason) {
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, wait, [&] {
    return interrupted_ || (!odometry_.empty() && odometry_.back().stamp_ns >= stamp_ns);
  });
  if (odometry_.empty()) {
    *reason = "no_odometry";
    return std::nullopt;
  }
  const auto after =
      std::lower_bound(odometry_.begin(), odometry_.end(), stamp_ns,
                       [](const dds::PlanarOdometry& o, int64_t t) { return o.stamp_ns < t; });
  dds::PlanarOdometry lo, hi;
  if (after == odometry_.end()) {
    lo = hi = odometry_.back();
  } else if (after->stamp_ns == stamp_ns || after == odometry_.begin()) {
    lo = hi = *after;
  } else {
    lo = *std::prev(after);
    hi = *after;
  }
  if (std::llabs(lo.stamp_ns - stamp_ns) > max_gap_ns &&
      std::llabs(hi.stamp_ns - stamp_ns) > max_gap_ns) {
    *reason = "odometry_too_far_from_image";
    return std::nullopt;
  }
  const double w = hi.stamp_ns == lo.stamp_ns ? 0.0
                                              : static_cast<double>(stamp_ns - lo.stamp_ns) /
                                                    static_cast<double>(hi.stamp_ns - lo.stamp_ns);
  const double dtheta = std::remainder(hi.theta - lo.theta, 2.0 * std::numbers::pi);
  return dds::PlanarOdometry{stamp_ns, (1 - w) * lo.x + w * hi.x, (1 - w) * lo.y + w * hi.y,
                             std::remainder(lo.theta + w * dtheta, 2.0 * std::numbers::pi)};
}

void SensorState::Interrupt() {
  {
    std::lock_guard lock(mutex_);
    interrupted_ = true;
  }
  changed_.notify_all();
}

}  // namespace epmap::mapping
