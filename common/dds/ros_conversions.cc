#include "common/dds/ros_conversions.h"

#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>

namespace epmap::dds {

int64_t ToNanoseconds(const builtin_interfaces::msg::Time& t) {
  return static_cast<int64_t>(t.sec()) * 1'000'000'000LL + static_cast<int64_t>(t.nanosec());
}

builtin_interfaces::msg::Time FromNanoseconds(int64_t ns) {
  builtin_interfaces::msg::Time t;
  int64_t sec = ns / 1'000'000'000LL;
  int64_t rem = ns % 1'000'000'000LL;
  if (rem < 0) {
    rem += 1'000'000'000LL;
    --sec;
  }
  t.sec(static_cast<int32_t>(sec));
  t.nanosec(static_cast<uint32_t>(rem));
  return t;
}

namespace {
struct EncodingInfo {
  int cv_type;
  int bytes_per_pixel;
};
std::optional<EncodingInfo> LookupEncoding(const std::string& encoding) {
  if (encoding == "mono8" || encoding == "8UC1") return EncodingInfo{CV_8UC1, 1};
  if (encoding == "bgr8" || encoding == "rgb8" || encoding == "8UC3") {
    return EncodingInfo{CV_8UC3, 3};
  }
  if (encoding == "mono16" || encoding == "16UC1") return EncodingInfo{CV_16UC1, 2};
  if (encoding == "32FC1") return EncodingInfo{CV_32FC1, 4};
  return std::nullopt;
}
}  // namespace

cv::Mat ImageToMat(const sensor_msgs::msg::Image& msg, std::string* reason) {
  const auto fail = [&](const char* why) {
    if (reason) *reason = why;
    return cv::Mat();
  };
  if (msg.width() == 0 || msg.height() == 0 || msg.data().empty()) return fail("empty");
  const auto enc = LookupEncoding(msg.encoding());
  if (!enc) return fail("unknown_encoding");
  const uint64_t row_bytes = static_cast<uint64_t>(msg.width()) * enc->bytes_per_pixel;
  if (msg.step() < row_bytes ||
      static_cast<uint64_t>(msg.step()) * msg.height() != msg.data().size()) {
    return fail("size_mismatch");
  }
  if (msg.is_bigendian() && enc->bytes_per_pixel > 1) return fail("big_endian");
  if (msg.width() > 16384 || msg.height() > 16384) return fail("size_mismatch");
  // Wrap the message's bytes with their own step, then copy into a compact Mat.
  const cv::Mat view(static_cast<int>(msg.height()), static_cast<int>(msg.width()), enc->cv_type,
                     const_cast<uint8_t*>(msg.data().data()), msg.step());
  cv::Mat out;
  if (msg.encoding() == "rgb8") {
    cv::cvtColor(view, out, cv::COLOR_RGB2BGR);
  } else {
    out = view.clone();
  }
  return out;
}

void MatToImage(const cv::Mat& image, int64_t stamp_ns, const std::string& frame_id,
                sensor_msgs::msg::Image* msg) {
  const char* encoding = nullptr;
  switch (image.type()) {
    case CV_8UC1:
      encoding = "mono8";
      break;
    case CV_8UC3:
      encoding = "bgr8";
      break;
    case CV_16UC1:
      encoding = "mono16";
      break;
    case CV_32FC1:
      encoding = "32FC1";
      break;
    default:
      throw std::invalid_argument("MatToImage: unsupported cv::Mat type");
  }
  msg->header().stamp(FromNanoseconds(stamp_ns));
  msg->header().frame_id(frame_id);
  msg->height(static_cast<uint32_t>(image.rows));
  msg->width(static_cast<uint32_t>(image.cols));
  msg->encoding(encoding);
  msg->is_bigendian(0);
  const size_t row_bytes = image.cols * image.elemSize();
  msg->step(static_cast<uint32_t>(row_bytes));
  auto& data = msg->data();
  data.resize(row_bytes * image.rows);
  if (image.isContinuous()) {
    std::memcpy(data.data(), image.data, data.size());
  } else {
    for (int r = 0; r < image.rows; ++r) {
      std::memcpy(data.data() + r * row_bytes, image.ptr(r), row_bytes);
    }
  }
}

std::optional<CameraCalibration> FromCameraInfo(const sensor_msgs::msg::CameraInfo& msg,
                                                std::string* reason) {
  CameraCalibration c;
  c.width = static_cast<int>(msg.width());
  c.height = static_cast<int>(msg.height());
  c.distortion_model = msg.distortion_model();
  c.d = msg.d();
  c.k = msg.k();
  c.r = msg.r();
  c.p = msg.p();
  bool finite = true;
  for (double v : c.d) finite &= std::isfinite(v);
  for (double v : c.k) finite &= std::isfinite(v);
  for (double v : c.r) finite &= std::isfinite(v);
  for (double v : c.p) finite &= std::isfinite(v);
  if (!finite || c.width <= 0 || c.height <= 0 || c.k[0] <= 0 || c.k[4] <= 0 || c.width > 16384 ||
      c.height > 16384) {
    if (reason) *reason = "camera_info_invalid";
    return std::nullopt;
  }
  // A driver that does not rectify leaves P zero: use K (ROS's convention for monocular).
  if (c.p[0] == 0.0) {
    c.p = {c.k[0], c.k[1], c.k[2], 0, c.k[3], c.k[4], c.k[5], 0, c.k[6], c.k[7], c.k[8], 0};
  }
  return c;
}

void ToCameraInfo(const CameraCalibration& calib, int64_t stamp_ns, const std::string& frame_id,
                  sensor_msgs::msg::CameraInfo* msg) {
  msg->header().stamp(FromNanoseconds(stamp_ns));
  msg->header().frame_id(frame_id);
  msg->width(static_cast<uint32_t>(calib.width));
  msg->height(static_cast<uint32_t>(calib.height));
  msg->distortion_model(calib.distortion_model);
  msg->d(calib.d);
  msg->k(calib.k);
  msg->r(calib.r);
  msg->p(calib.p);
  msg->binning_x(0);
  msg->binning_y(0);
}

std::optional<JointReading> FromJointState(const sensor_msgs::msg::JointState& msg,
                                           std::string* reason) {
  if (msg.name().empty() || msg.position().empty()) {
    if (reason) *reason = "empty";
    return std::nullopt;
  }
  if (msg.name().size() != msg.position().size()) {
    if (reason) *reason = "joints_size_mismatch";
    return std::nullopt;
  }
  for (double v : msg.position()) {
    if (!std::isfinite(v)) {
      if (reason) *reason = "joints_nan";
      return std::nullopt;
    }
  }
  return JointReading{ToNanoseconds(msg.header().stamp()), msg.name(), msg.position()};
}

void ToJointState(const JointReading& reading, sensor_msgs::msg::JointState* msg) {
  msg->header().stamp(FromNanoseconds(reading.stamp_ns));
  msg->header().frame_id("");
  msg->name(reading.names);
  msg->position(reading.positions);
  msg->velocity({});
  msg->effort({});
}

std::optional<PlanarOdometry> FromOdometry(const nav_msgs::msg::Odometry& msg,
                                           std::string* reason) {
  const auto& p = msg.pose().pose_value().position();
  const auto& q = msg.pose().pose_value().orientation();
  const double values[] = {p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w()};
  for (double v : values) {
    if (!std::isfinite(v)) {
      if (reason) *reason = "odom_nan";
      return std::nullopt;
    }
  }
  // Yaw of the quaternion (rotation about z).
  const double yaw = std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()),
                                1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z()));
  return PlanarOdometry{ToNanoseconds(msg.header().stamp()), p.x(), p.y(), yaw};
}

void ToOdometry(const PlanarOdometry& odom, const std::string& frame_id,
                const std::string& child_frame_id, nav_msgs::msg::Odometry* msg) {
  msg->header().stamp(FromNanoseconds(odom.stamp_ns));
  msg->header().frame_id(frame_id);
  msg->child_frame_id(child_frame_id);
  auto& pose = msg->pose().pose_value();
  pose.position().x(odom.x);
  pose.position().y(odom.y);
  pose.position().z(0.0);
  pose.orientation().x(0.0);
  pose.orientation().y(0.0);
  pose.orientation().z(std::sin(odom.theta / 2.0));
  pose.orientation().w(std::cos(odom.theta / 2.0));
}

}  // namespace epmap::dds
