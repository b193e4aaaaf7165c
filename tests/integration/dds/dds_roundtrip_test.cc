// Real Fast DDS between two participants in one process: images arrive intact over the
// image-sized transport, and the guarded type support refuses oversized and undecodable
// samples with a count instead of handing garbage on.

#include <epmap_dds/CameraInfoPubSubTypes.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <gtest/gtest.h>

#include <atomic>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <mutex>
#include <thread>
#include <tuple>

#include "clients/replay/dataset_publisher.h"
#include "common/dataset/dataset.h"
#include "common/dds/endpoints.h"
#include "common/dds/ros_conversions.h"
#include "tests/support/test_env.h"
#include "tests/support/wait_for.h"

namespace epmap {
namespace {

using ImageWriter = dds::Writer<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType>;
using ImageReader = dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType>;

using testing::WaitFor;

TEST(DdsRoundTrip, ImagesArriveIntactAndOversizedAreRefused) {
  const uint32_t domain = testing::UniqueDomainId(7);
  dds::Participant reader_side(domain, "reader");
  std::mutex mutex;
  std::vector<cv::Mat> received;
  ImageReader reader(
      reader_side, "rt/test/image",
      [&](sensor_msgs::msg::Image&& msg) {
        std::string reason;
        cv::Mat m = dds::ImageToMat(msg, &reason);
        std::lock_guard lock(mutex);
        received.push_back(m);
      },
      2'000'000);
  dds::Participant writer_side(domain, "writer");
  ImageWriter writer(writer_side, "rt/test/image");
  ASSERT_TRUE(writer.WaitForReaders(1, std::chrono::seconds(10)));
  ASSERT_TRUE(WaitFor([&] { return reader.MatchedWriters() > 0; }, std::chrono::seconds(10)));

  cv::Mat image(480, 640, CV_8UC3);
  cv::randu(image, 0, 255);
  sensor_msgs::msg::Image msg;
  dds::MatToImage(image, 1, "cam", &msg);
  ASSERT_TRUE(writer.Write(msg));
  ASSERT_TRUE(WaitFor(
      [&] {
        std::lock_guard l(mutex);
        return received.size() == 1;
      },
      std::chrono::seconds(10)));
  EXPECT_EQ(cv::norm(received[0], image, cv::NORM_INF), 0.0);

  cv::Mat big(1200, 1000, CV_8UC3, cv::Scalar(9, 9, 9));  // 3.6 MB > 2 MB limit
  dds::MatToImage(big, 2, "cam", &msg);
  ASSERT_TRUE(writer.Write(msg));
  EXPECT_TRUE(
      WaitFor([&] { return reader.counters().oversized.load() >= 1; }, std::chrono::seconds(10)));
  // The refused sample does not block the ones behind it, and is counted once.
  dds::MatToImage(image, 3, "cam", &msg);
  ASSERT_TRUE(writer.Write(msg));
  EXPECT_TRUE(WaitFor(
      [&] {
        std::lock_guard l(mutex);
        return received.size() == 2;
      },
      std::chrono::seconds(10)));
  EXPECT_EQ(reader.counters().oversized.load(), 1u);
  EXPECT_EQ(reader.counters().received.load(), 2u);
}

// epmap-replay --loop-for S sends what is scheduled in the first S seconds: a span shorter than
// one pass is not stretched to a whole pass, a longer one ends part-way through a pass.
TEST(DatasetReplay, LoopsForTheRequestedTimeOnly) {
  EPMAP_REQUIRE_SHARED_DATA("euroc-v101-excerpt");
  const dataset::Dataset euroc = dataset::Load(testing::SharedDataDir() / "euroc-v101-excerpt");
  ASSERT_EQ(euroc.frames.size(), 40u);  // 2 s at 20 Hz; the spans below end between two frames
  const uint32_t domain = testing::UniqueDomainId(11);
  dds::Participant reader_side(domain, "reader");
  std::atomic<int> received{0};
  ImageReader reader(
      reader_side, dds::TopicNames().left_image, [&](sensor_msgs::msg::Image&&) { received++; },
      8'000'000);
  // The replay waits for a reader on every stream it sends.
  ImageReader right(
      reader_side, dds::TopicNames().right_image, [](sensor_msgs::msg::Image&&) {}, 8'000'000);
  using InfoReader =
      dds::Reader<sensor_msgs::msg::CameraInfo, sensor_msgs::msg::CameraInfoPubSubType>;
  InfoReader left_info(
      reader_side, dds::TopicNames().left_info, [](sensor_msgs::msg::CameraInfo&&) {}, 64'000);
  InfoReader right_info(
      reader_side, dds::TopicNames().right_info, [](sensor_msgs::msg::CameraInfo&&) {}, 64'000);
  for (const auto& [seconds, frames, loops] :
       {std::tuple{1.025, 21, 1}, std::tuple{3.025, 61, 2}}) {
    received = 0;
    replay::ReplayOptions options;
    options.domain = domain;
    options.rate_hz = 20.0;
    options.loop_for_s = seconds;
    const replay::ReplayReport report = replay::Replay(euroc, options);
    EXPECT_EQ(report.frames, static_cast<size_t>(frames)) << seconds << " s";
    EXPECT_EQ(report.loops, static_cast<size_t>(loops)) << seconds << " s";
    // The schedule ends within the last frame period before the span (a stretched pass would
    // end at 2 or 4 s); the wall clock can only run later than the schedule, by however long a
    // loaded host takes to send, so it is checked from below only.
    EXPECT_LT(report.last_scheduled_s, seconds) << seconds << " s";
    EXPECT_GT(report.last_scheduled_s, seconds - 0.05 - 1e-6) << seconds << " s";
    EXPECT_GE(report.seconds, report.last_scheduled_s) << seconds << " s";
    EXPECT_TRUE(WaitFor([&] { return received.load() == frames; }, std::chrono::seconds(10)))
        << seconds << " s: " << received.load() << " images received";
  }
}

}  // namespace
}  // namespace epmap
