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

dds::CameraCalibration FromParameters(const stereo::CameraParameters& p) {
  dds::CameraCalibration c;
  c.width = p.width;
  c.height = p.height;
  c.distortion_model = p.distortion_model;
  c.d = p.d;
  c.k = p.k;
  c.r = p.r;
  c.p = p.p;
  return c;
}

}  // namespace

std::pair<dds::CameraCalibration, dds::CameraCalibration> CameraInfosFor(
    const dataset::Dataset& d) {
  stereo::CameraParameters left, right;
  if (d.rectified()) {
    for (auto* p : {&left, &right}) {
      const auto& cam = p == &left ? d.cam0 : d.cam1;
      p->width = cam.width;
      p->height = cam.height;
      p->distortion_model = "plumb_bob";
      p->d = {0, 0, 0, 0, 0};
      p->k = {cam.fu, 0, cam.cu, 0, cam.fv, cam.cv, 0, 0, 1};
      p->p = {cam.fu, 0, cam.cu, 0, 0, cam.fv, cam.cv, 0, 0, 0, 1, 0};
    }
    right.p[3] = -d.cam1.fu * d.baseline_m();
  } else {
    const std::string model =
        d.cam0.distortion_model == "equidistant" ? "equidistant" : "radial-tangential";
    stereo::StereoRectifyFromExtrinsics(
        K(d.cam0), d.cam0.distortion, K(d.cam1), d.cam1.distortion, ToCv(d.cam0.T_BS),
        ToCv(d.cam1.T_BS), cv::Size(d.cam0.width, d.cam0.height), model, &left, &right);
  }
  return {FromParameters(left), FromParameters(right)};
}

}  // namespace epmap::replay
