#include "perception/ep/generator/ep_generator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace epmap::ep {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

void CheckCamera(const stereo::RectifiedGeometry& camera) {
  if (camera.width <= 0 || camera.height <= 0 || !(camera.fx > 0) || !(camera.fy > 0) ||
      !(camera.baseline_m > 0)) {
    throw std::invalid_argument("EP generator: camera geometry is not set (size, focal, baseline)");
  }
}

void CheckInputs(const MapState& s, const stereo::RectifiedGeometry& camera,
                 const Eigen::Isometry3d& T) {
  CheckCamera(camera);
  const cv::Size size(camera.width, camera.height);
  if (s.points.type() != CV_32FC3 || s.points.size() != size) {
    throw std::invalid_argument("EP generator: points must be CV_32FC3 of the camera's size");
  }
  if (s.measured.type() != CV_8UC1 || s.measured.size() != size) {
    throw std::invalid_argument("EP generator: measured must be CV_8UC1 of the camera's size");
  }
  if (s.image.type() != CV_8UC1 || s.image.size() != size) {
    throw std::invalid_argument("EP generator: image must be CV_8UC1 of the camera's size");
  }
  if (s.accumulated.type() != CV_32FC1 || s.accumulated.size() != size) {
    throw std::invalid_argument("EP generator: accumulated must be CV_32FC1 of the camera's size");
  }
  if (!T.matrix().allFinite()) throw std::invalid_argument("EP generator: motion is not finite");
}

bool Finite(const cv::Vec3f& p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

}  // namespace

cv::Mat PointsFromDisparity(const cv::Mat& disparity, const stereo::RectifiedGeometry& camera,
                            double min_disparity_px) {
  CheckCamera(camera);
  if (disparity.type() != CV_32FC1 || disparity.size() != cv::Size(camera.width, camera.height)) {
    throw std::invalid_argument("points from disparity: CV_32FC1 of the camera's size expected");
  }
  const double fb = camera.fx * camera.baseline_m;
  cv::Mat points(disparity.size(), CV_32FC3);
  for (int v = 0; v < disparity.rows; ++v) {
    const float* d = disparity.ptr<float>(v);
    auto* p = points.ptr<cv::Vec3f>(v);
    const double y = (v - camera.cy) / camera.fy;
    for (int u = 0; u < disparity.cols; ++u) {
      if (!(d[u] > min_disparity_px) || !std::isfinite(d[u])) {
        p[u] = cv::Vec3f(kNaN, kNaN, kNaN);
        continue;
      }
      const double z = fb / d[u];
      p[u] = cv::Vec3f(static_cast<float>((u - camera.cx) / camera.fx * z),
                       static_cast<float>(y * z), static_cast<float>(z));
    }
  }
  return points;
}

Prediction Predict(const MapState& previous, const Eigen::Isometry3d& T_cur_prev,
                   const stereo::RectifiedGeometry& camera, const PredictionParams& params) {
  CheckInputs(previous, camera, T_cur_prev);
  const int W = camera.width, H = camera.height;
  const double fx = camera.fx, fy = camera.fy, cx = camera.cx, cy = camera.cy;
  const double fb = camera.fx * camera.baseline_m;  // z = fb / d
  const Eigen::Matrix3f R = T_cur_prev.linear().cast<float>();
  const Eigen::Vector3f t = T_cur_prev.translation().cast<float>();
  const float min_depth = static_cast<float>(params.min_depth_m);

  Prediction out;
  // 1. p_D (Sec. IV-B): every point X of frame k becomes X' = R X + t in frame k+1 and lands on
  //    the pixel nearest to its projection; the nearest point wins (z-buffer on depth).
  out.points = cv::Mat(H, W, CV_32FC3, cv::Scalar(kNaN, kNaN, kNaN));
  out.measured = cv::Mat(H, W, CV_8U, cv::Scalar(0));
  for (int v = 0; v < H; ++v) {
    const auto* src = previous.points.ptr<cv::Vec3f>(v);
    const uint8_t* m = previous.measured.ptr<uint8_t>(v);
    for (int u = 0; u < W; ++u) {
      if (!Finite(src[u])) continue;
      const Eigen::Vector3f X = R * Eigen::Vector3f(src[u][0], src[u][1], src[u][2]) + t;
      if (!(X.z() > min_depth)) continue;  // behind the new camera (or NaN)
      const double u1 = fx * X.x() / X.z() + cx, v1 = fy * X.y() / X.z() + cy;
      // Outside the image (the comparisons are false for NaN, too).
      if (!(u1 > -0.5 && v1 > -0.5 && u1 < W - 0.5 && v1 < H - 0.5)) continue;
      const int ui = static_cast<int>(u1 + 0.5), vi = static_cast<int>(v1 + 0.5);
      cv::Vec3f& dst = out.points.at<cv::Vec3f>(vi, ui);
      bool wins = !(dst[2] > 0);  // empty
      if (!wins) {
        const double d_new = fb / X.z(), d_old = fb / dst[2];
        if (std::abs(d_new - d_old) > params.crack_max_step_px) {
          wins = d_new > d_old;  // different surfaces: the nearer one hides the other
        } else {
          // One surface: the point nearer to the pixel centre keeps the grid regular (else
          // collisions here and gaps next door would multiply frame after frame).
          const double du_old = fx * dst[0] / dst[2] + cx - ui,
                       dv_old = fy * dst[1] / dst[2] + cy - vi;
          wins = (u1 - ui) * (u1 - ui) + (v1 - vi) * (v1 - vi) < du_old * du_old + dv_old * dv_old;
        }
      }
      if (wins) {
        dst = cv::Vec3f(X.x(), X.y(), X.z());
        out.measured.at<uint8_t>(vi, ui) = m[u];
      }
    }
  }
  // Cracks: an empty pixel whose neighbours (8-connected) hold at least three points of one
  // surface (disparities within crack_max_step_px) gets their average point, measured if most
  // of them are. An empty pixel
  // between two surfaces stays a hole: it may be a disocclusion, SGBM must look at it.
  const cv::Mat splat = out.points.clone();
  const cv::Mat splat_measured = out.measured.clone();
  for (int v = 1; v + 1 < H; ++v) {
    auto* dst = out.points.ptr<cv::Vec3f>(v);
    uint8_t* meas = out.measured.ptr<uint8_t>(v);
    for (int u = 1; u + 1 < W; ++u) {
      if (dst[u][2] > 0) continue;
      cv::Vec3f sum(0, 0, 0);
      int n = 0, n_measured = 0;
      double d_min = 1e30, d_max = -1e30;
      for (int dv = -1; dv <= 1; ++dv) {
        const auto* row = splat.ptr<cv::Vec3f>(v + dv);
        const uint8_t* mrow = splat_measured.ptr<uint8_t>(v + dv);
        for (int du = -1; du <= 1; ++du) {
          const cv::Vec3f& p = row[u + du];
          if (!(p[2] > 0)) continue;
          const double d = fb / p[2];
          d_min = std::min(d_min, d);
          d_max = std::max(d_max, d);
          sum += p;
          ++n;
          n_measured += mrow[u + du] ? 1 : 0;
        }
      }
      if (n >= 3 && d_max - d_min <= params.crack_max_step_px) {
        dst[u] = sum * (1.0F / static_cast<float>(n));
        // Measured if most neighbours are: "any unmeasured neighbour" would let the unknowns
        // of the map spread into the measurements a little more at every frame.
        meas[u] = 2 * n_measured > n ? 255 : 0;
      }
    }
  }

  // 2. p(L^k; T^{k+1}, D_-^{k+1}) and p(C^k; ...) (Sec. IV-A): each pixel centre of frame k+1 is
  //    back-projected at its point's depth, X' = z ray(u, v), moved back into frame k,
  //    X = R^T (X' - t), and projected there: q = pi(X). L^k and C^k are sampled at q.
  out.disparity.create(H, W, CV_32F);
  out.geometry.create(H, W, CV_32F);
  out.holes.create(H, W, CV_8U);
  cv::Mat map_x(H, W, CV_32F), map_y(H, W, CV_32F);
  const Eigen::Matrix3f Rt = R.transpose();
  int non_finite = 0;
  for (int v = 0; v < H; ++v) {
    auto* pts = out.points.ptr<cv::Vec3f>(v);
    float* disp = out.disparity.ptr<float>(v);
    float* geo = out.geometry.ptr<float>(v);
    uint8_t* meas = out.measured.ptr<uint8_t>(v);
    uint8_t* hole = out.holes.ptr<uint8_t>(v);
    float* mx = map_x.ptr<float>(v);
    float* my = map_y.ptr<float>(v);
    const float ray_y = static_cast<float>((v - cy) / fy);
    for (int u = 0; u < W; ++u) {
      bool ok = false;
      const float z = pts[u][2];
      if (z > min_depth) {
        const Eigen::Vector3f Xp(static_cast<float>((u - cx) / fx) * z, ray_y * z, z);
        const Eigen::Vector3f X = Rt * (Xp - t);
        const float qx = static_cast<float>(fx * X.x() / X.z() + cx);
        const float qy = static_cast<float>(fy * X.y() / X.z() + cy);
        const float d = static_cast<float>(fb / z);
        if (!std::isfinite(qx) || !std::isfinite(qy) || !std::isfinite(d) || !Finite(pts[u])) {
          ++non_finite;  // a point was there but the arithmetic broke down
        } else if (X.z() > min_depth && qx >= 0 && qy >= 0 && qx <= static_cast<float>(W - 1) &&
                   qy <= static_cast<float>(H - 1)) {
          mx[u] = qx;
          my[u] = qy;
          geo[u] = d;
          disp[u] = meas[u] ? d : kNaN;
          hole[u] = 0;
          ok = true;
        }
      }
      if (!ok) {
        // Nothing of frame k explains this pixel (or its sample would lie outside frame k).
        mx[u] = -1.0F;
        my[u] = -1.0F;
        geo[u] = kNaN;
        disp[u] = kNaN;
        hole[u] = 255;
        meas[u] = 0;
        pts[u] = cv::Vec3f(kNaN, kNaN, kNaN);
      }
    }
  }
  out.non_finite_rejected = non_finite;

  cv::Mat image_k;
  previous.image.convertTo(image_k, CV_32F);  // interpolate in float: no rounding of L_-
  cv::remap(image_k, out.image, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  cv::remap(previous.accumulated, out.accumulated, map_x, map_y, cv::INTER_LINEAR,
            cv::BORDER_CONSTANT, 0);
  // A non-finite C^k value would spread through the bilinear sample: never let it through.
  cv::patchNaNs(out.accumulated, 0.0);
  out.source_x = map_x;
  return out;
}

}  // namespace epmap::ep
