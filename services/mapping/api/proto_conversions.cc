#include "services/mapping/api/proto_conversions.h"

#include <cstring>
#include <stdexcept>

namespace epmap::mapping {

void ToProto(const cv::Mat& image, v1::FloatImage* out) {
  CV_Assert(image.type() == CV_32FC1);
  out->set_width(static_cast<uint32_t>(image.cols));
  out->set_height(static_cast<uint32_t>(image.rows));
  std::string* data = out->mutable_data();
  const size_t row_bytes = image.cols * sizeof(float);
  data->resize(row_bytes * image.rows);
  for (int r = 0; r < image.rows; ++r) {
    std::memcpy(data->data() + r * row_bytes, image.ptr(r), row_bytes);
  }
}

void ToProto(const cv::Mat& image, v1::ByteImage* out) {
  CV_Assert(image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3));
  out->set_width(static_cast<uint32_t>(image.cols));
  out->set_height(static_cast<uint32_t>(image.rows));
  out->set_channels(static_cast<uint32_t>(image.channels()));
  std::string* data = out->mutable_data();
  const size_t row_bytes = image.cols * image.elemSize();
  data->resize(row_bytes * image.rows);
  for (int r = 0; r < image.rows; ++r) {
    std::memcpy(data->data() + r * row_bytes, image.ptr(r), row_bytes);
  }
}

void ToProto(const stereo::RectifiedGeometry& g, const std::string& frame_id,
             v1::CameraModel* out) {
  out->set_width(static_cast<uint32_t>(g.width));
  out->set_height(static_cast<uint32_t>(g.height));
  out->set_fx(g.fx);
  out->set_fy(g.fy);
  out->set_cx(g.cx);
  out->set_cy(g.cy);
  out->set_baseline_m(g.baseline_m);
  out->set_frame_id(frame_id);
}

void ToProto(const Eigen::Vector3d& v, v1::Vector3* out) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

void ToProto(int64_t stamp_ns, const Eigen::Vector3d& xa, const Eigen::Vector3d& xb,
             const std::string& path, v1::EyeHandSample* out) {
  out->set_stamp_ns(stamp_ns);
  ToProto(xa, out->mutable_xa());
  ToProto(xb, out->mutable_xb());
  out->set_path(path);
}

const char* JobKindName(v1::JobKind kind) {
  switch (kind) {
    case v1::EYE_HAND:
      return "eye-hand";
    case v1::STEREO_EXTRINSICS:
      return "stereo-extrinsics";
    default:
      return "unspecified";
  }
}

v1::JobKind JobKindFromName(const std::string& name) {
  for (const v1::JobKind kind : {v1::EYE_HAND, v1::STEREO_EXTRINSICS}) {
    if (name == JobKindName(kind)) return kind;
  }
  return v1::JOB_KIND_UNSPECIFIED;
}

void ToProto(const Eigen::Isometry3d& T, const std::string& parent, const std::string& child,
             v1::Transform* out) {
  out->set_parent_frame(parent);
  out->set_child_frame(child);
  ToProto(Eigen::Vector3d(T.translation()), out->mutable_translation());
  const Eigen::Quaterniond q(T.linear());
  out->mutable_rotation()->set_w(q.w());
  out->mutable_rotation()->set_x(q.x());
  out->mutable_rotation()->set_y(q.y());
  out->mutable_rotation()->set_z(q.z());
}

cv::Mat FromProto(const v1::FloatImage& image) {
  const size_t expected = static_cast<size_t>(image.width()) * image.height() * sizeof(float);
  if (image.data().size() != expected || image.width() == 0 || image.height() == 0) {
    throw std::invalid_argument("FloatImage: data size does not match width x height");
  }
  cv::Mat out(static_cast<int>(image.height()), static_cast<int>(image.width()), CV_32FC1);
  std::memcpy(out.data, image.data().data(), expected);
  return out;
}

cv::Mat FromProto(const v1::ByteImage& image) {
  const size_t expected =
      static_cast<size_t>(image.width()) * image.height() * std::max(1u, image.channels());
  if (image.data().size() != expected || image.width() == 0 || image.height() == 0 ||
      (image.channels() != 1 && image.channels() != 3)) {
    throw std::invalid_argument("ByteImage: data size does not match width x height x channels");
  }
  cv::Mat out(static_cast<int>(image.height()), static_cast<int>(image.width()),
              image.channels() == 3 ? CV_8UC3 : CV_8UC1);
  std::memcpy(out.data, image.data().data(), expected);
  return out;
}

}  // namespace epmap::mapping
