// Bad input over real DDS into a real epmapd: every kind of refused sample is counted under its
// reason in GetStatus, nothing valid is lost, and the service keeps serving. An invalid RPC
// argument gets INVALID_ARGUMENT with a message.

#include <epmap_dds/CameraInfoPubSubTypes.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <epmap_dds/JointStatePubSubTypes.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fstream>
#include <opencv2/core.hpp>
#include <thread>

#include "common/dds/endpoints.h"
#include "common/dds/ros_conversions.h"
#include "common/dds/topics.h"
#include "tests/support/epmapd_fixture.h"

namespace epmap {
namespace {

// The left camera's frame as a ROS driver names it; the service's replies carry it.
constexpr const char* kLeftFrame = "stereo_left_optical";

using ImageWriter = dds::Writer<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType>;
using InfoWriter =
    dds::Writer<sensor_msgs::msg::CameraInfo, sensor_msgs::msg::CameraInfoPubSubType>;
using JointWriter =
    dds::Writer<sensor_msgs::msg::JointState, sensor_msgs::msg::JointStatePubSubType>;

// Raw bytes on the wire under the ROS Image type name: what a broken or hostile publisher
// sends. The payload claims a 2 GB frame_id string, which no decoder can satisfy.
class GarbageImageType : public eprosima::fastdds::dds::TopicDataType {
 public:
  GarbageImageType() {
    setName("sensor_msgs::msg::dds_::Image_");
    m_typeSize = 64;
    m_isGetKeyDefined = false;
  }
  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override {
    const auto& bytes = *static_cast<std::vector<uint8_t>*>(data);
    payload->data[0] = 0x00;  // CDR little-endian encapsulation
    payload->data[1] = 0x01;
    payload->data[2] = 0x00;
    payload->data[3] = 0x00;
    std::copy(bytes.begin(), bytes.end(), payload->data + 4);
    payload->length = static_cast<uint32_t>(4 + bytes.size());
    return true;
  }
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t*, void*) override { return false; }
  std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
    return [data] {
      return static_cast<uint32_t>(4 + static_cast<std::vector<uint8_t>*>(data)->size());
    };
  }
  void* createData() override { return new std::vector<uint8_t>(); }
  void deleteData(void* data) override { delete static_cast<std::vector<uint8_t>*>(data); }
  bool getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) override { return false; }
};

cv::Mat TexturedImage(int w, int h, int seed) {
  cv::Mat img(h, w, CV_8UC1);
  cv::RNG rng(static_cast<uint64_t>(seed));
  rng.fill(img, cv::RNG::UNIFORM, 0, 255);
  return img;
}

dds::CameraCalibration Rectified(int w, int h, double baseline) {
  return camera::Pinhole({w, h, 100, 100, w / 2.0, h / 2.0}, baseline);
}

class Publisher {
 public:
  explicit Publisher(uint32_t domain)
      : participant_(domain, "bad-input-test"),
        left_(participant_, dds::TopicNames().left_image),
        right_(participant_, dds::TopicNames().right_image),
        left_info_(participant_, dds::TopicNames().left_info),
        right_info_(participant_, dds::TopicNames().right_info),
        joints_(participant_, dds::TopicNames().joints) {}

  bool WaitMatched() {
    const auto t = std::chrono::seconds(15);
    const bool ok = left_.WaitForReaders(1, t) && right_.WaitForReaders(1, t) &&
                    left_info_.WaitForReaders(1, t) && right_info_.WaitForReaders(1, t) &&
                    joints_.WaitForReaders(1, t);
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    return ok;
  }

  void CameraInfos(int w, int h, int64_t stamp) {
    sensor_msgs::msg::CameraInfo msg;
    dds::ToCameraInfo(Rectified(w, h, 0.0), stamp, "cam0_optical", &msg);
    left_info_.Write(msg);
    dds::ToCameraInfo(Rectified(w, h, 0.1), stamp, "cam1_optical", &msg);
    right_info_.Write(msg);
  }
  void Left(sensor_msgs::msg::Image& msg) {
    Pace();
    left_.Write(msg);
  }
  void Right(sensor_msgs::msg::Image& msg) {
    Pace();
    right_.Write(msg);
  }
  void Pair(const cv::Mat& l, const cv::Mat& r, int64_t stamp) {
    sensor_msgs::msg::Image msg;
    dds::MatToImage(l, stamp, kLeftFrame, &msg);
    Left(msg);
    dds::MatToImage(r, stamp, "cam1_optical", &msg);
    Right(msg);
  }
  void Joints(const std::vector<double>& values, int64_t stamp) {
    sensor_msgs::msg::JointState msg;
    std::vector<std::string> names;
    for (size_t i = 0; i < values.size(); ++i) {
      std::string name = "j";  // (built in two steps: GCC 12 warns falsely on "j" + string)
      name += std::to_string(i);
      names.push_back(name);
    }
    dds::ToJointState({stamp, names, values}, &msg);
    Pace();
    joints_.Write(msg);
  }

 private:
  static void Pace() { std::this_thread::sleep_for(std::chrono::milliseconds(30)); }
  dds::Participant participant_;
  ImageWriter left_, right_;
  InfoWriter left_info_, right_info_;
  JointWriter joints_;
};

TEST(BadInputE2E, EveryRefusalIsCountedAndTheServiceKeepsServing) {
  const auto work = testing::FreshTempDir("bad-input");
  const uint32_t domain = testing::UniqueDomainId(202);
  // A small image limit so that "oversized" can be exercised with a modest sample.
  {
    std::ofstream config(work / "epmapd.yaml");
    config << "dds:\n  max_image_bytes: 200000\nstereo:\n  num_disparities: 16\n";
  }
  testing::Epmapd epmapd(domain, {"--config", (work / "epmapd.yaml").string()}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();

  Publisher pub(domain);
  ASSERT_TRUE(pub.WaitMatched());
  const int w = 160, h = 120;
  const int64_t s = 1'000'000'000;
  pub.CameraInfos(w, h, s);
  const cv::Mat img = TexturedImage(w, h, 1);

  // 1. A good pair.
  pub.Pair(img, img, s + 1);
  // 2. Width/height disagreeing with step and data.
  sensor_msgs::msg::Image bad;
  dds::MatToImage(img, s + 2, "cam0_optical", &bad);
  bad.step(w - 10);
  pub.Left(bad);
  // 3. Unknown encoding.
  dds::MatToImage(img, s + 3, "cam0_optical", &bad);
  bad.encoding("yuv_made_up");
  pub.Left(bad);
  // 4. Empty sample.
  sensor_msgs::msg::Image empty;
  empty.header().stamp(dds::FromNanoseconds(s + 4));
  pub.Left(empty);
  // 5. A pair whose images disagree in size.
  pub.Pair(img, TexturedImage(w / 2, h / 2, 2), s + 5);
  // 6. Stamps going backwards (after a good pair at s + 100).
  pub.Pair(img, img, s + 100);
  pub.Pair(img, img, s + 50);
  // 7. NaN joints.
  pub.Joints({0.1, std::nan("")}, s + 101);
  // 8. Oversized (640x480x3 > 200000 bytes).
  pub.Pair(cv::Mat(480, 640, CV_8UC3, cv::Scalar(1, 2, 3)), cv::Mat(480, 640, CV_8UC3), s + 200);
  // 9. Bytes that do not decode as an Image.
  {
    dds::Participant rogue(domain, "rogue");
    dds::Writer<std::vector<uint8_t>, GarbageImageType> garbage(rogue,
                                                                dds::TopicNames().left_image);
    ASSERT_TRUE(garbage.WaitForReaders(1, std::chrono::seconds(15)));
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    std::vector<uint8_t> bytes = {1, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0x7f, 'x', 'y'};
    garbage.Write(bytes);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  // 10. An image whose size differs from CameraInfo's.
  pub.Pair(TexturedImage(w + 16, h, 3), TexturedImage(w + 16, h, 3), s + 300);
  // 11. And the service still processes good frames.
  pub.Pair(img, img, s + 400);

  const auto status =
      epmapd.WaitStatus([](const v1::ServiceStatus& st) { return st.frames_processed() >= 3; },
                        std::chrono::seconds(20));
  const auto& r = status.rejected_by_reason();
  using testing::Epmapd;
  EXPECT_EQ(Epmapd::Count(r, "left_image:size_mismatch"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "left_image:unknown_encoding"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "left_image:empty"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "pair:size_mismatch"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "left_image:stamp_not_increasing"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "right_image:stamp_not_increasing"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "joint_states:joints_nan"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "left_image:oversized"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "right_image:oversized"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "left_image:malformed"), 1u) << status.DebugString();
  EXPECT_EQ(Epmapd::Count(r, "pipeline:image_size_differs_from_camera_info"), 1u)
      << status.DebugString();
  // Good pairs: s+1, s+100, s+400 (the pair at s+300 is refused by the pipeline).
  EXPECT_EQ(status.frames_processed(), 3u) << status.DebugString();
  EXPECT_EQ(status.last_stamp_ns(), s + 400);

  // The good frames' map, in the frame the left images named (it waited for its partner).
  {
    v1::DisparityMap newest;
    grpc::ClientContext newest_context;
    ASSERT_TRUE(epmapd.stub().GetDisparity(&newest_context, {}, &newest).ok());
    EXPECT_EQ(newest.stamp_ns(), s + 400);
    EXPECT_EQ(newest.camera().frame_id(), kLeftFrame);
  }

  // An invalid RPC argument: INVALID_ARGUMENT with a message a person can act on.
  v1::GetDisparityRequest request;
  request.set_wait_ms(999'999);
  v1::DisparityMap map;
  grpc::ClientContext context;
  const auto rpc = epmapd.stub().GetDisparity(&context, request, &map);
  EXPECT_EQ(rpc.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(rpc.error_message().find("wait_ms"), std::string::npos);

  // Still serving, then a clean stop on SIGINT.
  v1::ServiceStatus after;
  EXPECT_TRUE(epmapd.Status(&after).ok());
  epmapd.process().Signal(SIGINT);
  EXPECT_EQ(epmapd.process().Wait(std::chrono::seconds(10)), 0) << epmapd.process().Output();
  std::filesystem::remove_all(work);
}

}  // namespace
}  // namespace epmap
