#include "clients/replay/dataset_publisher.h"

#include <epmap_dds/CameraInfoPubSubTypes.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <epmap_dds/JointStatePubSubTypes.h>
#include <epmap_dds/OdometryPubSubTypes.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <thread>
#include <vector>

#include "clients/replay/camera_info_from_dataset.h"
#include "common/dds/endpoints.h"
#include "common/dds/ros_conversions.h"

namespace epmap::replay {

namespace {

using Clock = std::chrono::steady_clock;

// One thing to send, in time order.
struct Event {
  enum class Kind { kFrame, kJoints, kOdometry } kind;
  int64_t stamp_ns;
  size_t index;
};

int64_t MedianPeriodNs(const std::vector<dataset::StereoFrame>& frames) {
  if (frames.size() < 2) return 0;
  std::vector<int64_t> gaps;
  for (size_t i = 1; i < frames.size(); ++i)
    gaps.push_back(frames[i].stamp_ns - frames[i - 1].stamp_ns);
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  return gaps[gaps.size() / 2];
}

int64_t WallNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

ReplayReport Replay(const dataset::Dataset& d, const ReplayOptions& options) {
  dds::Participant participant(options.domain, "epmap-replay");
  using ImageWriter = dds::Writer<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType>;
  using InfoWriter =
      dds::Writer<sensor_msgs::msg::CameraInfo, sensor_msgs::msg::CameraInfoPubSubType>;
  using JointWriter =
      dds::Writer<sensor_msgs::msg::JointState, sensor_msgs::msg::JointStatePubSubType>;
  using OdomWriter = dds::Writer<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType>;
  ImageWriter left_image(participant, options.topics.left_image);
  ImageWriter right_image(participant, options.topics.right_image);
  InfoWriter left_info(participant, options.topics.left_info);
  InfoWriter right_info(participant, options.topics.right_info);
  std::unique_ptr<JointWriter> joints;
  std::unique_ptr<OdomWriter> odometry;
  if (!d.joints.empty())
    joints = std::make_unique<JointWriter>(participant, options.topics.joints, 50);
  if (!d.odometry.empty()) {
    odometry = std::make_unique<OdomWriter>(participant, options.topics.odom, 50);
  }

  // Nothing may be lost to discovery: wait until a reader matched every stream we send.
  const auto wait =
      std::chrono::milliseconds(static_cast<int64_t>(options.wait_for_reader_s * 1e3));
  const bool matched = left_image.WaitForReaders(1, wait) && right_image.WaitForReaders(1, wait) &&
                       left_info.WaitForReaders(1, wait) && right_info.WaitForReaders(1, wait) &&
                       (!joints || joints->WaitForReaders(1, wait)) &&
                       (!odometry || odometry->WaitForReaders(1, wait));
  if (!matched) {
    throw std::runtime_error("no reader matched on DDS domain " + std::to_string(options.domain) +
                             " within " + std::to_string(options.wait_for_reader_s) +
                             " s (is epmapd running there?)");
  }
  // Matching is symmetric but not simultaneous: give the readers' side a moment too.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));

  const auto [info_left, info_right] = CameraInfosFor(d);
  std::vector<Event> events;
  for (size_t i = 0; i < d.frames.size(); ++i) {
    events.push_back({Event::Kind::kFrame, d.frames[i].stamp_ns, i});
  }
  for (size_t i = 0; i < d.joints.size(); ++i) {
    events.push_back({Event::Kind::kJoints, d.joints[i].stamp_ns, i});
  }
  for (size_t i = 0; i < d.odometry.size(); ++i) {
    events.push_back({Event::Kind::kOdometry, d.odometry[i].stamp_ns, i});
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.stamp_ns < b.stamp_ns; });
  if (events.empty()) return {};

  // Decoded images, either preloaded or read as they are needed.
  std::vector<std::pair<cv::Mat, cv::Mat>> preloaded(
      std::min(options.preload_frames, d.frames.size()));
  const auto read = [&](size_t i) -> std::pair<cv::Mat, cv::Mat> {
    if (i < preloaded.size() && !preloaded[i].first.empty()) return preloaded[i];
    const auto& f = d.frames[i];
    cv::Mat l = cv::imread(f.left.string(), cv::IMREAD_UNCHANGED);
    cv::Mat r = cv::imread(f.right.string(), cv::IMREAD_UNCHANGED);
    if (l.empty() || r.empty()) {
      throw std::runtime_error("cannot read " + (l.empty() ? f.left : f.right).string());
    }
    return {l, r};
  };
  for (size_t i = 0; i < preloaded.size(); ++i) preloaded[i] = read(i);

  // Time scale: dataset time -> replay time.
  double scale = 1.0;
  const int64_t period = MedianPeriodNs(d.frames);
  if (options.rate_hz > 0.0 && period > 0) scale = (1e9 / options.rate_hz) / period;
  const int64_t t0_data = events.front().stamp_ns;
  // One pass lasts the sequence's span plus one frame period (so loops do not overlap).
  const int64_t pass_ns = static_cast<int64_t>(
      (events.back().stamp_ns - t0_data + std::max<int64_t>(period, 1)) * scale);
  const bool restamp = options.restamp || options.loop_for_s > 0.0;
  const int64_t wall0 = WallNs();
  const auto t0 = Clock::now();

  ReplayReport report;
  sensor_msgs::msg::Image image_msg;
  sensor_msgs::msg::CameraInfo info_msg;
  // Looping: what is scheduled before loop_for_s goes out, the last pass cut there (a span
  // shorter than one pass is not stretched to a whole one).
  const int64_t loop_end_ns = static_cast<int64_t>(options.loop_for_s * 1e9);
  bool done = false;
  for (size_t pass = 0; !done; ++pass) {
    for (const Event& e : events) {
      const int64_t offset_ns = static_cast<int64_t>(pass) * pass_ns +
                                static_cast<int64_t>((e.stamp_ns - t0_data) * scale);
      if (loop_end_ns > 0 && offset_ns >= loop_end_ns) {
        done = true;
        break;
      }
      std::this_thread::sleep_until(t0 + std::chrono::nanoseconds(offset_ns));
      report.last_scheduled_s = offset_ns * 1e-9;
      // Restamped messages carry the wall-clock time they were meant to be sent at.
      const int64_t stamp = restamp ? wall0 + offset_ns : e.stamp_ns;
      switch (e.kind) {
        case Event::Kind::kFrame: {
          const auto [l, r] = read(e.index);
          // As a ROS driver: CameraInfo with the same stamp, then the images.
          dds::ToCameraInfo(info_left, stamp, "cam0_optical", &info_msg);
          left_info.Write(info_msg);
          dds::ToCameraInfo(info_right, stamp, "cam1_optical", &info_msg);
          right_info.Write(info_msg);
          dds::MatToImage(l, stamp, "cam0_optical", &image_msg);
          left_image.Write(image_msg);
          dds::MatToImage(r, stamp, "cam1_optical", &image_msg);
          right_image.Write(image_msg);
          report.frames++;
          break;
        }
        case Event::Kind::kJoints: {
          sensor_msgs::msg::JointState msg;
          dds::ToJointState({stamp, d.joint_names, d.joints[e.index].positions}, &msg);
          joints->Write(msg);
          report.joint_states++;
          break;
        }
        case Event::Kind::kOdometry: {
          const auto& o = d.odometry[e.index];
          nav_msgs::msg::Odometry msg;
          dds::ToOdometry({stamp, o.x, o.y, o.theta}, "odom", "base_link", &msg);
          odometry->Write(msg);
          report.odometry++;
          break;
        }
      }
    }
    report.loops = pass + 1;
    if (loop_end_ns <= 0 || static_cast<int64_t>(pass + 1) * pass_ns >= loop_end_ns) done = true;
  }
  report.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  std::this_thread::sleep_for(
      std::chrono::milliseconds(static_cast<int64_t>(options.linger_s * 1e3)));
  return report;
}

}  // namespace epmap::replay
