// epmap-sim publish on its own DDS domain, received by common/dds readers in this process:
// every frame arrives, with images identical to what the library renders for the same options,
// camera_info of a rectified driver and joint states at the image stamps.

#include <gtest/gtest.h>

#include <epmap_dds/CameraInfoPubSubTypes.h>
#include <epmap_dds/EyeHandSamplesPubSubTypes.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <epmap_dds/JointStatePubSubTypes.h>
#include <epmap_dds/OdometryPubSubTypes.h>
#include <epmap_dds/StringPubSubTypes.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>

#include "clients/sim/scenario.h"
#include "common/dds/endpoints.h"
#include "common/dds/participant.h"
#include "common/dds/ros_conversions.h"
#include "common/dds/topics.h"
#include "tests/e2e/sim/run_command.h"
#include "tests/support/test_env.h"
#include "tests/support/wait_for.h"

namespace epmap::sim {
namespace {

TEST(EpmapSimPublish, EveryFrameArrivesIntact) {
  const uint32_t domain = epmap::testing::UniqueDomainId(11);
  const dds::TopicNames topics;
  dds::Participant participant(domain, "sim-publish-test");
  std::mutex mutex;
  std::map<int64_t, cv::Mat> left, right;
  std::vector<dds::CameraCalibration> right_infos;
  std::vector<dds::JointReading> joints;
  const uint32_t kMax = 8u << 20;
  // Each camera's images by stamp.
  const auto images_by_stamp = [&](std::map<int64_t, cv::Mat>* into) {
    return [&mutex, into](sensor_msgs::msg::Image&& m) {
      std::string reason;
      cv::Mat img = dds::ImageToMat(m, &reason);
      std::lock_guard lock(mutex);
      (*into)[dds::ToNanoseconds(m.header().stamp())] = img;
    };
  };
  dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> left_reader(
      participant, topics.left_image, images_by_stamp(&left), kMax, 50);
  dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> right_reader(
      participant, topics.right_image, images_by_stamp(&right), kMax, 50);
  dds::Reader<sensor_msgs::msg::CameraInfo, sensor_msgs::msg::CameraInfoPubSubType> info_reader(
      participant, topics.right_info,
      [&](sensor_msgs::msg::CameraInfo&& m) {
        std::string reason;
        auto c = dds::FromCameraInfo(m, &reason);
        std::lock_guard lock(mutex);
        if (c) right_infos.push_back(*c);
      },
      1u << 20, 50);
  dds::Reader<sensor_msgs::msg::JointState, sensor_msgs::msg::JointStatePubSubType> joint_reader(
      participant, topics.joints,
      [&](sensor_msgs::msg::JointState&& m) {
        std::string reason;
        auto j = dds::FromJointState(m, &reason);
        std::lock_guard lock(mutex);
        if (j) joints.push_back(*j);
      },
      1u << 20, 50);

  // The URDF, latched as robot_state_publisher does.
  std::vector<std::string> descriptions;
  dds::Reader<std_msgs::msg::String, std_msgs::msg::StringPubSubType> description_reader(
      participant, topics.robot_description,
      [&](std_msgs::msg::String&& m) {
        std::lock_guard lock(mutex);
        descriptions.push_back(m.data());
      },
      1u << 20, 1, dds::Durability::kTransientLocal);

  constexpr int kFrames = 6;
  const auto r = testing::RunCommand(
      (epmap::testing::BinDir() / "epmap-sim").string() + " publish --scenario head --domain " +
      std::to_string(domain) + " --frames " + std::to_string(kFrames) + " --size 160x120 --seed 5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // Every topic had its reader before the first frame. (A warning that frames went out late is
  // the shared host's doing under a parallel test run, not a fault: seen once in CTest -j2.)
  EXPECT_EQ(r.output.find("no reader matched"), std::string::npos) << r.output;

  ScenarioOptions o;
  o.name = "head";
  o.frames = kFrames;
  o.width = 160;
  o.height = 120;
  o.seed = 5;
  const auto scenario = MakeScenario(o);
  std::lock_guard lock(mutex);
  ASSERT_EQ(left.size(), static_cast<size_t>(kFrames));
  ASSERT_EQ(right.size(), static_cast<size_t>(kFrames));
  ASSERT_EQ(joints.size(), static_cast<size_t>(kFrames));
  ASSERT_EQ(right_infos.size(), static_cast<size_t>(kFrames));
  ASSERT_EQ(descriptions.size(), 1u);
  EXPECT_EQ(descriptions[0], scenario->urdf());
  int i = 0;
  int64_t first = left.begin()->first;
  for (const auto& [stamp, image] : left) {
    const SimFrame f = scenario->Render(i);
    // Stamps: the wall clock at the start plus the scenario's frame times.
    EXPECT_EQ(stamp - first, f.stamp_ns - scenario->StampNs(0));
    ASSERT_TRUE(right.count(stamp));
    EXPECT_EQ(cv::norm(image, f.left, cv::NORM_INF), 0) << "left frame " << i;
    EXPECT_EQ(cv::norm(right.at(stamp), f.right, cv::NORM_INF), 0) << "right frame " << i;
    EXPECT_EQ(joints[static_cast<size_t>(i)].stamp_ns, stamp);
    EXPECT_EQ(joints[static_cast<size_t>(i)].names, scenario->joint_names());
    EXPECT_EQ(joints[static_cast<size_t>(i)].positions, f.joints);
    ++i;
  }
  const double fx = scenario->cam0().fu;
  EXPECT_NEAR(right_infos[0].baseline_from_p(), 0.068, 1e-9);
  EXPECT_DOUBLE_EQ(right_infos[0].p[0], fx);
  EXPECT_DOUBLE_EQ(right_infos[0].k[0], fx);
}

TEST(EpmapSimPublish, BuildingSendsGreyImagesAndOdometry) {
  const uint32_t domain = epmap::testing::UniqueDomainId(12);
  const dds::TopicNames topics;
  dds::Participant participant(domain, "sim-publish-building-test");
  std::mutex mutex;
  std::vector<cv::Mat> images;
  std::vector<dds::PlanarOdometry> odometry;
  dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> left_reader(
      participant, topics.left_image,
      [&](sensor_msgs::msg::Image&& m) {
        std::string reason;
        cv::Mat img = dds::ImageToMat(m, &reason);
        std::lock_guard lock(mutex);
        images.push_back(img);
      },
      8u << 20, 50);
  dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> right_reader(
      participant, topics.right_image, [](sensor_msgs::msg::Image&&) {}, 8u << 20, 50);
  dds::Reader<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType> odom_reader(
      participant, topics.odom,
      [&](nav_msgs::msg::Odometry&& m) {
        std::string reason;
        auto o = dds::FromOdometry(m, &reason);
        std::lock_guard lock(mutex);
        if (o) odometry.push_back(*o);
      },
      1u << 20, 50);
  const auto r = testing::RunCommand((epmap::testing::BinDir() / "epmap-sim").string() +
                                     " publish --scenario building --domain " +
                                     std::to_string(domain) + " --frames 12 --size 80x60");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::lock_guard lock(mutex);
  ASSERT_EQ(images.size(), 12u);
  EXPECT_EQ(images[0].type(), CV_8UC1);
  ASSERT_EQ(odometry.size(), 12u);
  // The robot drives off after its first look-around (7 frames).
  EXPECT_GT(odometry.back().x, 0.1);
}

// --max-frames caps what is sent and, unlike --frames, stops quietly at the route's end
// (scripts/demo.sh --seconds uses it without knowing how long the route is).
TEST(EpmapSimPublish, MaxFramesStopsAtTheEndOfTheRoute) {
  const uint32_t domain = epmap::testing::UniqueDomainId(14);
  const dds::TopicNames topics;
  dds::Participant participant(domain, "sim-publish-max-frames-test");
  std::atomic<int> received{0};
  dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> left_reader(
      participant, topics.left_image, [&](sensor_msgs::msg::Image&&) { ++received; }, 8u << 20, 50);
  dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> right_reader(
      participant, topics.right_image, [](sensor_msgs::msg::Image&&) {}, 8u << 20, 50);
  const std::string publish = (epmap::testing::BinDir() / "epmap-sim").string() +
                              " publish --scenario building --domain " + std::to_string(domain) +
                              " --size 80x60 --first-frame 1844";  // 5 frames before the end
  const auto capped = testing::RunCommand(publish + " --max-frames 3");
  ASSERT_EQ(capped.exit_code, 0) << capped.output;
  EXPECT_NE(capped.output.find("sent 3 stereo frames"), std::string::npos) << capped.output;
  EXPECT_TRUE(
      epmap::testing::WaitFor([&] { return received.load() == 3; }, std::chrono::seconds(5)));
  received = 0;
  const auto to_the_end = testing::RunCommand(publish + " --max-frames 500");
  ASSERT_EQ(to_the_end.exit_code, 0) << to_the_end.output;
  EXPECT_NE(to_the_end.output.find("sent 5 stereo frames"), std::string::npos) << to_the_end.output;
  EXPECT_TRUE(
      epmap::testing::WaitFor([&] { return received.load() == 5; }, std::chrono::seconds(5)));
  const auto too_many = testing::RunCommand(publish + " --frames 500");
  EXPECT_NE(too_many.exit_code, 0);
  EXPECT_NE(too_many.output.find("--frames 500 is more"), std::string::npos) << too_many.output;
  const auto negative = testing::RunCommand(publish + " --max-frames -2");
  EXPECT_NE(negative.exit_code, 0);
}

TEST(EpmapSimPublish, EyeHandSendsOneMessagePerPath) {
  const uint32_t domain = epmap::testing::UniqueDomainId(13);
  const dds::TopicNames topics;
  dds::Participant participant(domain, "sim-publish-eye-hand-test");
  std::mutex mutex;
  std::map<std::string, size_t> per_path;
  dds::Reader<epmap_msgs::msg::EyeHandSamples, epmap_msgs::msg::EyeHandSamplesPubSubType> reader(
      participant, topics.eye_hand_samples,
      [&](epmap_msgs::msg::EyeHandSamples&& m) {
        std::lock_guard lock(mutex);
        for (const auto& s : m.samples()) per_path[s.path()]++;
      },
      4u << 20, 50);
  const auto r = testing::RunCommand((epmap::testing::BinDir() / "epmap-sim").string() +
                                     " publish --scenario eye-hand --rate 20 --domain " +
                                     std::to_string(domain));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::lock_guard lock(mutex);
  ASSERT_EQ(per_path.size(), 20u);
  for (const auto& [path, n] : per_path) EXPECT_EQ(n, 100u) << path;
}

}  // namespace
}  // namespace epmap::sim
