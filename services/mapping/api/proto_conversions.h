#pragma once
// cv::Mat / Eigen <-> epmap.v1 messages.

#include <epmap/v1/calibration_service.pb.h>
#include <epmap/v1/common.pb.h>
#include <Eigen/Geometry>

#include <opencv2/core.hpp>

#include "perception/stereo/rectification.h"

namespace epmap::mapping {

void ToProto(const cv::Mat& image_f32, v1::FloatImage* out);  // CV_32FC1
void ToProto(const cv::Mat& image_u8, v1::ByteImage* out);    // CV_8UC1 or CV_8UC3
// frame_id: the camera frame the images are in (MapSnapshot::camera_frame()).
void ToProto(const stereo::RectifiedGeometry& g, const std::string& frame_id, v1::CameraModel* out);
void ToProto(const Eigen::Isometry3d& T, const std::string& parent, const std::string& child,
             v1::Transform* out);
void ToProto(const Eigen::Vector3d& v, v1::Vector3* out);
// One eye-hand sample (paper 001: X_A where stereo saw the end effector, X_B where the
// kinematics puts it, ROOT frame) as CalibrationService takes it. Fields, not a struct: the
// service, the simulator and the CSV reader each have their own sample type.
void ToProto(int64_t stamp_ns, const Eigen::Vector3d& xa, const Eigen::Vector3d& xb,
             const std::string& path, v1::EyeHandSample* out);

// A calibration job kind's name, as the service's model ids ("eye-hand-3") and epmapctl use it
// ("unspecified" for JOB_KIND_UNSPECIFIED), and back (JOB_KIND_UNSPECIFIED for an unknown name).
const char* JobKindName(v1::JobKind kind);
v1::JobKind JobKindFromName(const std::string& name);

// Client side: messages back to cv::Mat (throws std::invalid_argument if sizes disagree).
cv::Mat FromProto(const v1::FloatImage& image);
cv::Mat FromProto(const v1::ByteImage& image);

}  // namespace epmap::mapping
