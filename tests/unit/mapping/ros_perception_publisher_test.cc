// The EP's output for ROS 2 (services/mapping/ros_output/ros_perception_publisher.h): the
// disparity in stereo_msgs/DisparityImage's convention, and the publisher over real DDS, which
// converts nothing while no reader listens.

#include "services/mapping/ros_output/ros_perception_publisher.h"

#include <epmap_dds/DisparityImage.h>
#include <epmap_dds/DisparityImagePubSubTypes.h>
#include <epmap_dds/Image.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>

#include "common/dds/endpoints.h"
#include "common/dds/ros_conversions.h"
#include "tests/support/test_env.h"
#include "tests/support/wait_for.h"

namespace epmap::mapping {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A 6x4 frame: disparities 10 + column, two unknown pixels; something moved at (1, 2).
std::shared_ptr<const MapSnapshot> Frame(uint64_t index, const std::string& frame_id) {
  auto s = std::make_shared<MapSnapshot>();
  s->frame_index = index;
  s->stamp_ns = 1'403'715'273'262'142'976LL + static_cast<int64_t>(index);
  s->frame_id = frame_id;
  s->camera.width = 6;
  s->camera.height = 4;
  s->camera.fx = 251.0;
  s->camera.baseline_m = 0.12;
  s->min_disparity = 2;
  s->num_disparities = 64;
  s->disparity.create(4, 6, CV_32FC1);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 6; ++c) s->disparity.at<float>(r, c) = 10.0f + c + 0.25f * r;
  }
  s->disparity.at<float>(0, 0) = kNaN;
  s->disparity.at<float>(3, 5) = kNaN;
  auto ep = std::make_shared<ep::EpResult>();
  ep->unexpected = cv::Mat::zeros(4, 6, CV_8UC1);
  ep->unexpected.at<uint8_t>(2, 1) = 255;
  s->ep = std::move(ep);
  return s;
}

float PixelAt(const sensor_msgs::msg::Image& image, int r, int c) {
  float v;
  std::memcpy(&v, image.data().data() + r * image.step() + c * sizeof(float), sizeof(float));
  return v;
}

TEST(RosPerceptionPublisher, TheDisparityFollowsStereoMsgsConventions) {
  const auto frame = Frame(3, "cam0_optical");
  stereo_msgs::msg::DisparityImage msg;
  ToRosDisparity(*frame, &msg);
  EXPECT_EQ(dds::ToNanoseconds(msg.header().stamp()), frame->stamp_ns);
  EXPECT_EQ(msg.header().frame_id(), "cam0_optical");
  EXPECT_EQ(msg.image().header().frame_id(), "cam0_optical");
  EXPECT_EQ(msg.image().encoding(), "32FC1");
  EXPECT_EQ(msg.image().width(), 6u);
  EXPECT_EQ(msg.image().height(), 4u);
  EXPECT_EQ(msg.image().step(), 24u);
  ASSERT_EQ(msg.image().data().size(), 96u);
  // Known values unchanged; unknown ones below min_disparity, which ROS reads as invalid.
  EXPECT_FLOAT_EQ(PixelAt(msg.image(), 2, 3), 13.5f);
  EXPECT_FLOAT_EQ(PixelAt(msg.image(), 0, 0), 1.0f);
  EXPECT_LT(PixelAt(msg.image(), 3, 5), msg.min_disparity());
  EXPECT_FLOAT_EQ(msg.f(), 251.0f);
  EXPECT_FLOAT_EQ(msg.t(), 0.12f);
  EXPECT_FLOAT_EQ(msg.min_disparity(), 2.0f);
  EXPECT_FLOAT_EQ(msg.max_disparity(), 65.0f);
  EXPECT_FLOAT_EQ(msg.delta_d(), 1.0f / 16.0f);
  EXPECT_EQ(msg.valid_window().width(), 6u);
  EXPECT_EQ(msg.valid_window().height(), 4u);
  // Depth from the message as a ROS node computes it: Z = f t / d.
  EXPECT_NEAR(msg.f() * msg.t() / PixelAt(msg.image(), 1, 2), 251.0 * 0.12 / 12.25, 1e-5);
  // A publisher that sent no frame_id: the chain's camera link.
  ToRosDisparity(*Frame(4, ""), &msg);
  EXPECT_EQ(msg.header().frame_id(), "cam0_optical");
  // Nothing to convert is an error, not an empty message.
  MapSnapshot empty;
  EXPECT_THROW(ToRosDisparity(empty, &msg), std::invalid_argument);
}

using testing::WaitFor;

// Nothing is converted or written while nobody listens; a reader that joins gets the next
// frame's disparity and mask, as they were computed.
TEST(RosPerceptionPublisher, PublishesWhileAReaderListensOnly) {
  dds::Participant participant(testing::UniqueDomainId(37), "ros_perception_publisher_test");
  const std::string suffix = std::to_string(::getpid());
  ServiceConfig config;
  config.topics.disparity = "disparity_" + suffix;
  config.topics.unexpected_mask = "unexpected_" + suffix;
  CounterSet events;
  SnapshotStore snapshots;
  RosPerceptionPublisher publisher(config, participant, snapshots, events);
  snapshots.Publish(Frame(1, "left_cam"));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(events.Get("ros_disparity_published"), 0u);
  EXPECT_EQ(events.Get("ros_unexpected_mask_published"), 0u);

  std::mutex mutex;
  std::optional<stereo_msgs::msg::DisparityImage> disparity;
  std::optional<sensor_msgs::msg::Image> mask;
  dds::Reader<stereo_msgs::msg::DisparityImage, stereo_msgs::msg::DisparityImagePubSubType>
      disparity_reader(
          participant, dds::RosTopic(config.topics.disparity),
          [&](stereo_msgs::msg::DisparityImage&& m) {
            std::lock_guard l(mutex);
            disparity = std::move(m);
          },
          1u << 20);
  dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> mask_reader(
      participant, dds::RosTopic(config.topics.unexpected_mask),
      [&](sensor_msgs::msg::Image&& m) {
        std::lock_guard l(mutex);
        mask = std::move(m);
      },
      1u << 20);
  ASSERT_TRUE(
      WaitFor([&] { return disparity_reader.MatchedWriters() > 0; }, std::chrono::seconds(10)));
  ASSERT_TRUE(WaitFor([&] { return mask_reader.MatchedWriters() > 0; }, std::chrono::seconds(10)));
  // Writer-side matching can lag the reader's by a moment: publish until both arrive.
  uint64_t index = 2;
  ASSERT_TRUE(WaitFor(
      [&] {
        snapshots.Publish(Frame(index++, "left_cam"));
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        std::lock_guard l(mutex);
        return disparity && mask;
      },
      std::chrono::seconds(10)));
  std::lock_guard l(mutex);
  EXPECT_EQ(disparity->header().frame_id(), "left_cam");
  EXPECT_FLOAT_EQ(PixelAt(disparity->image(), 2, 3), 13.5f);
  EXPECT_FLOAT_EQ(PixelAt(disparity->image(), 0, 0), 1.0f);
  EXPECT_EQ(mask->encoding(), "mono8");
  ASSERT_EQ(mask->data().size(), 24u);
  EXPECT_EQ(mask->data()[2 * 6 + 1], 255);
  EXPECT_EQ(mask->data()[0], 0);
  EXPECT_GE(events.Get("ros_disparity_published"), 1u);
  EXPECT_GE(events.Get("ros_unexpected_mask_published"), 1u);
}

// The mask needs the EP; an empty topic name turns one output off.
TEST(RosPerceptionPublisher, EachOutputCanBeTurnedOff) {
  dds::Participant participant(testing::UniqueDomainId(41), "ros_perception_publisher_off");
  const std::string suffix = std::to_string(::getpid());
  ServiceConfig config;
  config.topics.disparity = "";
  config.topics.unexpected_mask = "unexpected_off_" + suffix;
  config.ep.enabled = false;
  CounterSet events;
  SnapshotStore snapshots;
  dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> mask_reader(
      participant, dds::RosTopic(config.topics.unexpected_mask), [](sensor_msgs::msg::Image&&) {},
      1u << 20);
  RosPerceptionPublisher publisher(config, participant, snapshots, events);
  snapshots.Publish(Frame(1, "cam"));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(mask_reader.MatchedWriters(), 0);
  EXPECT_EQ(events.Get("ros_disparity_published"), 0u);
  EXPECT_EQ(events.Get("ros_unexpected_mask_published"), 0u);
}

}  // namespace
}  // namespace epmap::mapping
