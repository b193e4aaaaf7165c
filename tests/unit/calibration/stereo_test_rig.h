#pragma once
// The rig and scene helpers shared by the stereo self-calibration tests.

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

#include "perception/calibration/stereo_self_calibration.h"
#include "tests/unit/calibration/synthetic_stereo.h"

namespace epmap::calibration::testing {

constexpr int kWidth = 560, kHeight = 420;

inline CameraIntrinsics Camera() {
  CameraIntrinsics c;
  c.width = kWidth;
  c.height = kHeight;
  c.k << 440, 0, 283, 0, 440, 207, 0, 0, 1;
  return c;
}

inline Eigen::Isometry3d TrueExtrinsics() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translate(Eigen::Vector3d(0.068, 0.0015, -0.001));
  t.rotate(Eigen::AngleAxisd(-0.07, Eigen::Vector3d::UnitY()) *
           Eigen::AngleAxisd(0.004, Eigen::Vector3d::UnitX()));
  return t;
}

// The prior the kinematics would give with biased eye encoders: the truth rotated a bit.
inline Eigen::Isometry3d Perturbed(const Eigen::Isometry3d& t, double degrees) {
  Eigen::Isometry3d p = t;
  p.rotate(Eigen::AngleAxisd(degrees * M_PI / 180, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()));
  return p;
}

inline StereoView RenderView(const std::vector<TexturedQuad>& scene, const Eigen::Isometry3d& truth,
                             const Eigen::Isometry3d& prior) {
  const CameraIntrinsics c = Camera();
  StereoView v;
  v.left = Render(scene, c.k, Eigen::Isometry3d::Identity(), {kWidth, kHeight});
  v.right = Render(scene, c.k, truth, {kWidth, kHeight});
  v.T_cam0_cam1_prior = prior;
  return v;
}

inline ErrorCode CodeOf(const std::function<void()>& f, std::string* message = nullptr) {
  try {
    f();
  } catch (const CalibrationError& e) {
    if (message) *message = e.what();
    return e.code();
  }
  ADD_FAILURE() << "no CalibrationError thrown";
  return ErrorCode::kNotConverged;
}

// Median |dy| of SIFT matches between two rectified images.
inline double MedianVerticalOffset(const cv::Mat& l, const cv::Mat& r) {
  std::vector<Eigen::Vector2d> pl, pr;
  MatchSift(l, r, 2000, 0.7, true, &pl, &pr);
  std::vector<double> dy;
  for (size_t i = 0; i < pl.size(); ++i) dy.push_back(std::abs(pl[i].y() - pr[i].y()));
  if (dy.empty()) return 1e9;
  std::nth_element(dy.begin(), dy.begin() + static_cast<std::ptrdiff_t>(dy.size() / 2), dy.end());
  return dy[dy.size() / 2];
}

}  // namespace epmap::calibration::testing
