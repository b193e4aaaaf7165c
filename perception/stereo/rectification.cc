#include "perception/stereo/rectification.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace epmap::stereo {

namespace {

cv::Matx33d K(const CameraParameters& c) {
  return cv::Matx33d(c.k.data());
}
cv::Matx33d R(const CameraParameters& c) {
  return cv::Matx33d(c.r.data());
}
cv::Matx33d P33(const CameraParameters& c) {
  return {c.p[0], c.p[1], c.p[2], c.p[4], c.p[5], c.p[6], c.p[8], c.p[9], c.p[10]};
}

bool AllZero(const std::vector<double>& d) {
  for (double v : d) {
    if (v != 0.0) return false;
  }
  return true;
}

bool Near(const cv::Matx33d& a, const cv::Matx33d& b) {
  return cv::norm(a - b) < 1e-9;
}

bool AlreadyRectified(const CameraParameters& c) {
  return AllZero(c.d) && Near(R(c), cv::Matx33d::eye()) && Near(P33(c), K(c));
}

void BuildMap(const CameraParameters& c, cv::Mat& mx, cv::Mat& my) {
  const cv::Size size(c.width, c.height);
  const cv::Mat d(c.d, true);
  if (c.distortion_model == "equidistant") {
    cv::fisheye::initUndistortRectifyMap(K(c), d, R(c), P33(c), size, CV_16SC2, mx, my);
  } else {
    cv::initUndistortRectifyMap(K(c), d, R(c), P33(c), size, CV_16SC2, mx, my);
  }
}

}  // namespace

Rectifier::Rectifier(const CameraParameters& left, const CameraParameters& right) {
  if (left.width <= 0 || left.height <= 0 || left.width != right.width ||
      left.height != right.height) {
    throw std::invalid_argument("left and right cameras must have the same positive size");
  }
  if (left.k[0] <= 0 || left.k[4] <= 0 || right.k[0] <= 0 || right.k[4] <= 0 || left.p[0] <= 0 ||
      right.p[0] <= 0) {
    throw std::invalid_argument("focal lengths in K and P must be positive");
  }
  const double baseline = -right.p[3] / right.p[0];
  if (!(std::abs(baseline) > 1e-6) || !std::isfinite(baseline)) {
    throw std::invalid_argument("the right camera's P carries no baseline (P[3] = -fx * B)");
  }
  geometry_ = {left.width, left.height, left.p[0],         left.p[5],
               left.p[2],  left.p[6],   std::abs(baseline)};
  identity_ = AlreadyRectified(left) && AlreadyRectified(right);
  left_rotation_ = R(left);
  if (!identity_) {
    BuildMap(left, map_left_x_, map_left_y_);
    BuildMap(right, map_right_x_, map_right_y_);
  }
}

void Rectifier::Rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left,
                        cv::Mat& right) const {
  if (identity_) {
    left = left_raw;
    right = right_raw;
    return;
  }
  cv::remap(left_raw, left, map_left_x_, map_left_y_, cv::INTER_LINEAR);
  cv::remap(right_raw, right, map_right_x_, map_right_y_, cv::INTER_LINEAR);
}

void StereoRectifyFromExtrinsics(const cv::Matx33d& k_left, const std::vector<double>& d_left,
                                 const cv::Matx33d& k_right, const std::vector<double>& d_right,
                                 const cv::Matx44d& T_body_left, const cv::Matx44d& T_body_right,
                                 const cv::Size& size, const std::string& distortion_model,
                                 CameraParameters* left, CameraParameters* right) {
  // Pose of the left camera in the right camera's frame: T_right_left = T_BR^-1 T_BL.
  const cv::Matx44d T_rl = T_body_right.inv() * T_body_left;
  const cv::Matx33d R_rl(T_rl(0, 0), T_rl(0, 1), T_rl(0, 2), T_rl(1, 0), T_rl(1, 1), T_rl(1, 2),
                         T_rl(2, 0), T_rl(2, 1), T_rl(2, 2));
  const cv::Vec3d t_rl(T_rl(0, 3), T_rl(1, 3), T_rl(2, 3));
  cv::Mat R1, R2, P1, P2, Q;
  const cv::Mat dl(d_left, true);
  const cv::Mat dr(d_right, true);
  if (distortion_model == "equidistant") {
    cv::fisheye::stereoRectify(k_left, dl, k_right, dr, size, R_rl, t_rl, R1, R2, P1, P2, Q,
                               cv::CALIB_ZERO_DISPARITY, size, 0.0, 1.0);
  } else {
    cv::stereoRectify(k_left, dl, k_right, dr, size, R_rl, t_rl, R1, R2, P1, P2, Q,
                      cv::CALIB_ZERO_DISPARITY, 0.0, size);
  }
  const auto fill = [&](CameraParameters* c, const cv::Matx33d& k, const std::vector<double>& d,
                        const cv::Mat& r, const cv::Mat& p) {
    c->width = size.width;
    c->height = size.height;
    c->distortion_model = distortion_model == "equidistant" ? "equidistant" : "plumb_bob";
    c->d = d;
    for (int i = 0; i < 9; ++i) c->k[static_cast<size_t>(i)] = k.val[i];
    for (int i = 0; i < 9; ++i) c->r[static_cast<size_t>(i)] = r.at<double>(i / 3, i % 3);
    for (int i = 0; i < 12; ++i) c->p[static_cast<size_t>(i)] = p.at<double>(i / 4, i % 4);
  };
  fill(left, k_left, d_left, R1, P1);
  fill(right, k_right, d_right, R2, P2);
}

}  // namespace epmap::stereo
