#include <gtest/gtest.h>

#include <cmath>

#include "common/dds/ros_conversions.h"

namespace epmap {
namespace {

TEST(RosConversions, ImageRoundTripAndRgbToBgr) {
  cv::Mat bgr(3, 4, CV_8UC3);
  cv::randu(bgr, 0, 255);
  sensor_msgs::msg::Image msg;
  dds::MatToImage(bgr, 42, "cam0", &msg);
  EXPECT_EQ(msg.encoding(), "bgr8");
  EXPECT_EQ(msg.step(), 12u);
  std::string reason;
  const cv::Mat back = dds::ImageToMat(msg, &reason);
  EXPECT_EQ(cv::norm(back, bgr, cv::NORM_INF), 0.0);
  msg.encoding("rgb8");
  const cv::Mat swapped = dds::ImageToMat(msg, &reason);
  EXPECT_EQ(swapped.at<cv::Vec3b>(1, 2)[0], bgr.at<cv::Vec3b>(1, 2)[2]);
}

TEST(RosConversions, ImageValidationReasons) {
  sensor_msgs::msg::Image msg;
  dds::MatToImage(cv::Mat(4, 4, CV_8UC1, cv::Scalar(0)), 1, "", &msg);
  std::string reason;
  auto bad = msg;
  bad.step(3);
  EXPECT_TRUE(dds::ImageToMat(bad, &reason).empty());
  EXPECT_EQ(reason, "size_mismatch");
  bad = msg;
  bad.height(5);
  EXPECT_TRUE(dds::ImageToMat(bad, &reason).empty());
  EXPECT_EQ(reason, "size_mismatch");
  bad = msg;
  bad.encoding("bayer_unheard_of");
  EXPECT_TRUE(dds::ImageToMat(bad, &reason).empty());
  EXPECT_EQ(reason, "unknown_encoding");
  EXPECT_TRUE(dds::ImageToMat(sensor_msgs::msg::Image(), &reason).empty());
  EXPECT_EQ(reason, "empty");
  // A step with row padding is fine.
  auto padded = msg;
  padded.step(6);
  padded.data().resize(24);
  EXPECT_FALSE(dds::ImageToMat(padded, &reason).empty());
}

TEST(RosConversions, TimeAndJointsAndOdometry) {
  EXPECT_EQ(dds::ToNanoseconds(dds::FromNanoseconds(1'403'715'273'262'142'976LL)),
            1'403'715'273'262'142'976LL);
  EXPECT_EQ(dds::ToNanoseconds(dds::FromNanoseconds(-5)), -5);
  sensor_msgs::msg::JointState js;
  js.name({"a", "b"});
  js.position({0.1, std::nan("")});
  std::string reason;
  EXPECT_FALSE(dds::FromJointState(js, &reason));
  EXPECT_EQ(reason, "joints_nan");
  js.position({0.1});
  EXPECT_FALSE(dds::FromJointState(js, &reason));
  EXPECT_EQ(reason, "joints_size_mismatch");
  nav_msgs::msg::Odometry odom;
  dds::ToOdometry({7, 1.0, 2.0, 2.5}, "odom", "base", &odom);
  const auto back = dds::FromOdometry(odom, &reason);
  ASSERT_TRUE(back);
  EXPECT_NEAR(back->theta, 2.5, 1e-12);
  EXPECT_EQ(back->stamp_ns, 7);
}

TEST(RosConversions, CameraInfoValidation) {
  sensor_msgs::msg::CameraInfo info;
  std::string reason;
  EXPECT_FALSE(dds::FromCameraInfo(info, &reason));
  EXPECT_EQ(reason, "camera_info_invalid");
  dds::CameraCalibration c;
  c.width = 10;
  c.height = 10;
  c.k = {5, 0, 5, 0, 5, 5, 0, 0, 1};
  dds::ToCameraInfo(c, 1, "cam0", &info);
  const auto back = dds::FromCameraInfo(info, &reason);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->p[0], 5.0);  // P falls back to K when the driver leaves it zero
}

}  // namespace
}  // namespace epmap
