#include "clients/sim/publish.h"

#include <epmap_dds/CameraInfoPubSubTypes.h>
#include <epmap_dds/EyeHandSamplesPubSubTypes.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <epmap_dds/JointStatePubSubTypes.h>
#include <epmap_dds/OdometryPubSubTypes.h>
#include <epmap_dds/StringPubSubTypes.h>

#include <algorithm>
#include <condition_variable>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "common/dds/endpoints.h"
#include "common/dds/participant.h"
#include "common/dds/ros_conversions.h"

namespace epmap::sim {

namespace {

using Clock = std::chrono::steady_clock;

int64_t WallClockNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

void Log(const PublishOptions& o, const std::string& message) {
  if (o.log) o.log(message);
}

// Frames rendered ahead by a few worker threads, handed to the sender in index order. A worker
// waits while it is more than `ahead` frames in front of the sender.
class RenderAhead {
 public:
  // limit > 0: only the first `limit` frames (or all, when the scenario has fewer).
  RenderAhead(const Scenario& scenario, int workers, int ahead, int limit)
      : scenario_(scenario),
        ahead_(ahead),
        total_(limit > 0 ? std::min(limit, scenario.frame_count()) : scenario.frame_count()) {
    for (int w = 0; w < workers; ++w) threads_.emplace_back([this] { Work(); });
  }
  ~RenderAhead() { Stop(); }

  // The next frame in order; nullopt after the last one (or once stopped). Rethrows a
  // rendering error.
  std::optional<SimFrame> Next() {
    std::unique_lock lock(mutex_);
    ready_.wait(lock, [&] { return stopped_ || error_ || done_.count(next_) || next_ >= total_; });
    if (error_) std::rethrow_exception(error_);
    if (stopped_ || next_ >= total_) return std::nullopt;
    SimFrame f = std::move(done_.at(next_));
    done_.erase(next_++);
    space_.notify_all();
    return f;
  }

  void Stop() {
    {
      std::lock_guard lock(mutex_);
      stopped_ = true;
    }
    ready_.notify_all();
    space_.notify_all();
    for (auto& t : threads_) {
      if (t.joinable()) t.join();
    }
  }

 private:
  void Work() {
    while (true) {
      int index;
      {
        std::unique_lock lock(mutex_);
        space_.wait(lock,
                    [&] { return stopped_ || claimed_ >= total_ || claimed_ < next_ + ahead_; });
        if (stopped_ || claimed_ >= total_) return;
        index = claimed_++;
      }
      try {
        SimFrame f = scenario_.RenderSensors(index);
        std::lock_guard lock(mutex_);
        done_.emplace(index, std::move(f));
      } catch (...) {
        std::lock_guard lock(mutex_);
        error_ = std::current_exception();
      }
      ready_.notify_all();
    }
  }

  const Scenario& scenario_;
  const int ahead_, total_;
  std::mutex mutex_;
  std::condition_variable ready_, space_;
  std::map<int, SimFrame> done_;
  int next_ = 0, claimed_ = 0;
  bool stopped_ = false;
  std::exception_ptr error_;
  std::vector<std::thread> threads_;
};

PublishReport PublishEyeHand(const Scenario& scenario, const PublishOptions& o) {
  dds::Participant participant(o.domain_id, "epmap-sim");
  dds::Writer<epmap_msgs::msg::EyeHandSamples, epmap_msgs::msg::EyeHandSamplesPubSubType> writer(
      participant, o.topics.eye_hand_samples);
  PublishReport report;
  report.readers_matched = writer.WaitForReaders(1, o.wait_for_readers);
  if (!report.readers_matched) {
    Log(o, "warning: no reader matched " + o.topics.eye_hand_samples + " within " +
               std::to_string(o.wait_for_readers.count()) + " ms; sending anyway");
  }
  std::this_thread::sleep_for(o.grace);
  // One message per path, in path order.
  std::map<std::string, std::vector<EyeHandSample>> paths;
  for (const auto& s : scenario.EyeHandSamples()) paths[s.path].push_back(s);
  const double rate = o.rate_hz > 0 ? o.rate_hz : scenario.rate_hz();
  const int64_t wall0 = WallClockNs();
  report.first_stamp_ns = wall0;
  const auto t0 = Clock::now();
  const int64_t scenario0 = scenario.options().start_stamp_ns;
  int n = 0;
  for (const auto& [name, samples] : paths) {
    if (o.stop_requested && o.stop_requested()) break;
    if (!o.as_fast_as_possible) {
      std::this_thread::sleep_until(t0 + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(n / rate)));
    }
    epmap_msgs::msg::EyeHandSamples msg;
    const int64_t stamp = wall0 + (samples.back().stamp_ns - scenario0);
    msg.header().stamp(dds::FromNanoseconds(stamp));
    msg.header().frame_id("base_link");
    msg.set_name("sim-eye-hand-seed" + std::to_string(scenario.options().seed));
    for (const auto& s : samples) {
      epmap_msgs::msg::EyeHandSample m;
      m.stamp(dds::FromNanoseconds(wall0 + (s.stamp_ns - scenario0)));
      m.xa({s.xa.x(), s.xa.y(), s.xa.z()});
      m.xb({s.xb.x(), s.xb.y(), s.xb.z()});
      m.path(s.path);
      msg.samples().push_back(m);
    }
    writer.Write(msg);
    ++n;
  }
  report.frames_sent = n;
  report.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  writer.WaitForAcknowledgments(std::chrono::milliseconds(2000));
  std::this_thread::sleep_for(o.grace);
  return report;
}

}  // namespace

PublishReport Publish(const Scenario& scenario, const PublishOptions& o) {
  if (!(o.rate_hz >= 0)) throw std::invalid_argument("publish rate must be >= 0 Hz");
  if (o.render_threads < 1) throw std::invalid_argument("publish needs at least 1 render thread");
  if (o.max_frames < 0) throw std::invalid_argument("publish: max_frames must be >= 0");
  if (scenario.frame_count() == 0) return PublishEyeHand(scenario, o);

  dds::Participant participant(o.domain_id, "epmap-sim");
  using ImageWriter = dds::Writer<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType>;
  using InfoWriter =
      dds::Writer<sensor_msgs::msg::CameraInfo, sensor_msgs::msg::CameraInfoPubSubType>;
  ImageWriter left(participant, o.topics.left_image);
  ImageWriter right(participant, o.topics.right_image);
  InfoWriter left_info(participant, o.topics.left_info);
  InfoWriter right_info(participant, o.topics.right_info);
  dds::Writer<sensor_msgs::msg::JointState, sensor_msgs::msg::JointStatePubSubType> joints(
      participant, o.topics.joints);
  std::unique_ptr<dds::Writer<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType>> odom;
  if (scenario.has_odometry()) {
    odom =
        std::make_unique<dds::Writer<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType>>(
            participant, o.topics.odom);
  }

  // The robot's URDF latched as robot_state_publisher does (depth 1, transient local): a reader
  // that joins while this runs still gets it, e.g. `epmapd --urdf-topic rt/robot_description`.
  std::unique_ptr<dds::Writer<std_msgs::msg::String, std_msgs::msg::StringPubSubType>> description;
  if (!o.topics.robot_description.empty()) {
    description =
        std::make_unique<dds::Writer<std_msgs::msg::String, std_msgs::msg::StringPubSubType>>(
            participant, o.topics.robot_description, 1, dds::Durability::kTransientLocal);
    std_msgs::msg::String urdf;
    urdf.data(scenario.urdf());
    description->Write(urdf);
  }

  // Render ahead while discovery runs: two workers, so that a frame's ~25 ms of rendering on
  // one core leaves room for sending at 30 Hz.
  RenderAhead frames(scenario, o.render_threads, 6, o.max_frames);

  PublishReport report;
  const auto deadline = Clock::now() + o.wait_for_readers;
  const auto remaining = [&] {
    return std::chrono::duration_cast<std::chrono::milliseconds>(
        std::max(Clock::duration::zero(), deadline - Clock::now()));
  };
  report.readers_matched =
      left.WaitForReaders(1, remaining()) && right.WaitForReaders(1, remaining());
  if (!report.readers_matched) {
    Log(o, "warning: no reader matched both image topics within " +
               std::to_string(o.wait_for_readers.count()) + " ms; sending anyway");
  }
  // The other topics are optional (a viewer may read images only), so each gets at most the
  // grace period to match: a reader that exists, discovered a little later than the images' on
  // a busy host, then does not miss the first joint state or CameraInfo.
  left_info.WaitForReaders(1, o.grace);
  right_info.WaitForReaders(1, o.grace);
  joints.WaitForReaders(1, o.grace);
  if (odom) odom->WaitForReaders(1, o.grace);
  std::this_thread::sleep_for(o.grace);

  const dataset::CameraSensor cam0 = scenario.cam0(), cam1 = scenario.cam1();
  const double baseline = scenario.rectified() ? (cam0.T_BS.inverse() * cam1.T_BS)(0, 3) : 0.0;
  // CameraInfo of a calibrated driver (REP 104): a rectified pair's right camera has
  // P[3] = -fx * B; an unrectified rig (baseline 0 here) has P = K [I | 0].
  const dds::CameraCalibration calib0 = camera::Pinhole(cam0.pinhole());
  const dds::CameraCalibration calib1 = camera::Pinhole(cam1.pinhole(), baseline);
  const std::vector<std::string> names = scenario.joint_names();
  const double rate = o.rate_hz > 0 ? o.rate_hz : scenario.rate_hz();
  const int64_t scenario0 = scenario.StampNs(0);

  sensor_msgs::msg::Image left_msg, right_msg;
  sensor_msgs::msg::CameraInfo info_msg;
  sensor_msgs::msg::JointState joint_msg;
  const int64_t wall0 = WallClockNs();
  report.first_stamp_ns = wall0;
  const auto t0 = Clock::now();
  int sent = 0;
  while (auto frame = frames.Next()) {
    if (o.stop_requested && o.stop_requested()) break;
    if (!o.as_fast_as_possible) {
      const auto due = t0 + std::chrono::duration_cast<Clock::duration>(
                                std::chrono::duration<double>(sent / rate));
      const double late_ms = std::chrono::duration<double, std::milli>(Clock::now() - due).count();
      if (late_ms > 5) {
        ++report.late_frames;
        report.max_late_ms = std::max(report.max_late_ms, late_ms);
      } else {
        std::this_thread::sleep_until(due);
      }
    }
    // The frame's stamp on the wall clock; at a custom rate, frame i is due at i / rate.
    const int64_t stamp =
        rate == scenario.rate_hz()
            ? wall0 + (frame->stamp_ns - scenario0)
            : wall0 + static_cast<int64_t>(std::llround(frame->index * 1e9 / rate));
    dds::ToJointState({stamp, names, frame->joints}, &joint_msg);
    joints.Write(joint_msg);
    if (odom && frame->odometry) {
      nav_msgs::msg::Odometry odom_msg;
      dds::ToOdometry({stamp, frame->odometry->x, frame->odometry->y, frame->odometry->theta},
                      "odom", "base_link", &odom_msg);
      odom->Write(odom_msg);
    }
    dds::ToCameraInfo(calib0, stamp, "cam0_optical", &info_msg);
    left_info.Write(info_msg);
    dds::ToCameraInfo(calib1, stamp, "cam1_optical", &info_msg);
    right_info.Write(info_msg);
    dds::MatToImage(frame->left, stamp, "cam0_optical", &left_msg);
    dds::MatToImage(frame->right, stamp, "cam1_optical", &right_msg);
    left.Write(left_msg);
    right.Write(right_msg);
    ++sent;
  }
  frames.Stop();
  report.frames_sent = sent;
  report.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  // Let reliable readers catch up before the participant goes away: every topic, not only the
  // images (a reader counting joint states or CameraInfos could miss the last ones on a busy host).
  const auto ack_wait = std::chrono::milliseconds(2000);
  left.WaitForAcknowledgments(ack_wait);
  right.WaitForAcknowledgments(ack_wait);
  left_info.WaitForAcknowledgments(ack_wait);
  right_info.WaitForAcknowledgments(ack_wait);
  joints.WaitForAcknowledgments(ack_wait);
  if (odom) odom->WaitForAcknowledgments(ack_wait);
  std::this_thread::sleep_for(o.grace);
  if (report.max_late_ms > 100) {
    Log(o, "warning: " + std::to_string(report.late_frames) + " of " + std::to_string(sent) +
               " frames went out more than 5 ms after their time, the latest by " +
               std::to_string(static_cast<int>(report.max_late_ms)) +
               " ms (rendering could not keep up with " + std::to_string(rate) + " Hz)");
  }
  return report;
}

}  // namespace epmap::sim
