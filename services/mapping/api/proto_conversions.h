#pragma once
// cv::Mat / Eigen <-> epmap.v1 messages.

#include <Eigen/Geometry>
#include <epmap/v1/common.pb.h>

#include <opencv2/core.hpp>

#include "perception/stereo/rectification.h"

namespace epmap::mapping {

void ToProto(const cv::Mat& image_f32, v1::FloatImage* out);   // CV_32FC1
void ToProto(const cv::Mat& image_u8, v1::ByteImage* out);     // CV_8UC1 or CV_8UC3
void ToProto(const stereo::RectifiedGeometry& g, v1::CameraModel* out);
void ToProto(const Eigen::Isometry3d& T, const std::string& parent, const std::string& child,
             v1::Transform* out);
void ToProto(const Eigen::Vector3d& v, v1::Vector3* out);

// Client side: messages back to cv::Mat (throws std::invalid_argument if sizes disagree).
cv::Mat FromProto(const v1::FloatImage& image);
cv::Mat FromProto(const v1::ByteImage& image);

}  // namespace epmap::mapping
