#include "clients/replay/camera_info_from_dataset.h"

#include "perception/stereo/rectification.h"

namespace epmap::replay {

namespace {

cv::Matx33d K(const dataset::CameraSensor& c) {
  return {c.fu, 0, c.cu, 0, c.fv, c.cv, 0, 0, 1};
}

cv::Matx44d ToCv(const Eigen::Matrix4d& m) {
  cv::Matx44d out;
  for (int i = 0; i < 16; ++i) out.val[i] = m(i / 4, i % 4);
  return out;
}

}  // namespace

std::pair<dds::CameraCalibration, dds::CameraCalibration> CameraInfosFor(
    const dataset::Dataset& d) {
  stereo::CameraParameters left, right;
  if (d.rectified()) {
    left = camera::Pinhole(d.cam0.pinhole());
    right = camera::Pinhole(d.cam1.pinhole(), d.baseline_m());
  } else {
    const std::string model =
        d.cam0.distortion_model == "equidistant" ? "equidistant" : "radial-tangential";
    stereo::StereoRectifyFromExtrinsics(
        K(d.cam0), d.cam0.distortion, K(d.cam1), d.cam1.distortion, ToCv(d.cam0.T_BS),
        ToCv(d.cam1.T_BS), cv::Size(d.cam0.width, d.cam0.height), model, &left, &right);
  }
  return {left, right};
}

}  // namespace epmap::replay
