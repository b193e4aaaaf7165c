#pragma once
// One camera's calibration as sensor_msgs/CameraInfo carries it (REP 104). The same struct is
// what DDS ingest reads (dds::CameraCalibration) and what rectification consumes
// (stereo::CameraParameters), so nothing copies it field by field between the two.

#include <array>
#include <string>
#include <utility>
#include <vector>

namespace epmap::camera {

struct CameraModel {
  int width = 0;
  int height = 0;
  std::string distortion_model = "plumb_bob";          // or "equidistant"
  std::vector<double> d;                               // distortion coefficients
  std::array<double, 9> k{};                           // intrinsics, row-major
  std::array<double, 9> r{1, 0, 0, 0, 1, 0, 0, 0, 1};  // rectifying rotation
  std::array<double, 12> p{};                          // projection of the rectified camera

  // Baseline (metres) of a right camera from P: P[3] = -fx' * B (REP 104).
  double baseline_from_p() const { return p[0] != 0.0 ? -p[3] / p[0] : 0.0; }
};

// A distortion-free pinhole camera's size and intrinsics (pixels).
struct PinholeIntrinsics {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

// A distortion-free pinhole camera with R = I: K, D = 0, P = K [I | t] with P[3] = -fx B for
// the right camera of a rectified pair at baseline B (REP 104); B = 0 gives a left or lone camera.
inline CameraModel Pinhole(const PinholeIntrinsics& in, double baseline_m = 0.0) {
  CameraModel c;
  c.width = in.width;
  c.height = in.height;
  c.d = {0, 0, 0, 0, 0};
  c.k = {in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1};
  c.p = {in.fx, 0, in.cx, -in.fx * baseline_m, 0, in.fy, in.cy, 0, 0, 0, 1, 0};
  return c;
}

// An already-rectified pair sharing one set of intrinsics, the right camera B to the right.
inline std::pair<CameraModel, CameraModel> RectifiedPinholePair(const PinholeIntrinsics& in,
                                                                double baseline_m) {
  return {Pinhole(in), Pinhole(in, baseline_m)};
}

}  // namespace epmap::camera
