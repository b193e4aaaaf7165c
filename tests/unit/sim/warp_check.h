#pragma once
// Exactness checks shared by the scenario tests: re-project each left pixel into the right
// image through the true geometry and compare intensities.

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "clients/sim/scenario.h"

namespace epmap::sim::testing {

// Scenarios are built once per binary: their textures take a few hundred milliseconds.
inline const Scenario& Shared(const ScenarioOptions& o) {
  static std::map<std::string, std::unique_ptr<Scenario>> cache;
  const std::string key =
      o.name + "/" + std::to_string(o.width) + "x" + std::to_string(o.height) + "/" +
      std::to_string(o.frames) + "/" + std::to_string(o.seed) + "/" + std::to_string(o.noise) +
      std::to_string(o.reverse) + std::to_string(o.walker) + "/" + o.route + "/" +
      std::to_string(o.first_frame) + "/" + std::to_string(o.encoder_noise_scale) + "/" +
      std::to_string(o.flicker_scale) + "/" + std::to_string(o.passes) + "/" +
      std::to_string(o.odometry_scale_error) + "/" + std::to_string(o.supersample);
  auto& s = cache[key];
  if (!s) s = MakeScenario(o);
  return *s;
}

struct WarpStats {
  size_t visible = 0;     // left pixels whose true point is seen by the right camera too
  size_t consistent = 0;  // of those, right image (bilinear) within the tolerance of the left
  double consistent_share() const { return visible ? double(consistent) / visible : 0.0; }
};

// Bilinear sample of channel c at (x, y); false outside.
inline bool SampleBilinear(const cv::Mat& img, double x, double y, int c, double* out) {
  if (x < 0 || y < 0 || x > img.cols - 1 || y > img.rows - 1) return false;
  const int x0 = std::min(static_cast<int>(x), img.cols - 2);
  const int y0 = std::min(static_cast<int>(y), img.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const int C = img.channels();
  const auto at = [&](int yy, int xx) { return double(img.ptr<uint8_t>(yy)[xx * C + c]); };
  *out = (1 - fx) * (1 - fy) * at(y0, x0) + fx * (1 - fy) * at(y0, x0 + 1) +
         (1 - fx) * fy * at(y0 + 1, x0) + fx * fy * at(y0 + 1, x0 + 1);
  return true;
}

// For every left pixel with a known depth: its 3-D point goes through the true T_cam0_cam1
// into the right camera (fx, fy, cx, cy shared). It counts as visible in both if the right
// depth buffer there agrees (within 0.5%), and as consistent if every channel of the
// right image, sampled there, is within `tolerance` grey levels of the left pixel.
inline WarpStats WarpRightIntoLeft(const SimFrame& f, const dataset::CameraSensor& cam,
                                   double tolerance) {
  WarpStats stats;
  const Eigen::Isometry3d T_1_0 = f.gt_T_cam0_cam1.inverse();
  const int C = f.left.channels();
  for (int y = 0; y < f.left.rows; ++y) {
    for (int x = 0; x < f.left.cols; ++x) {
      const float z = f.gt_depth.at<float>(y, x);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d p0(z * (x - cam.cu) / cam.fu, z * (y - cam.cv) / cam.fv, z);
      const Eigen::Vector3d p1 = T_1_0 * p0;
      if (p1.z() <= 0) continue;
      const double u = cam.fu * p1.x() / p1.z() + cam.cu, v = cam.fv * p1.y() / p1.z() + cam.cv;
      const int ui = static_cast<int>(std::lround(u)), vi = static_cast<int>(std::lround(v));
      if (ui < 0 || vi < 0 || ui >= f.right.cols || vi >= f.right.rows) continue;
      const float zr = f.gt_depth_right.at<float>(vi, ui);
      if (!std::isfinite(zr) || std::abs(zr - p1.z()) > 0.005 * p1.z()) continue;
      bool ok = true, inside = true;
      for (int c = 0; c < C; ++c) {
        double r = 0;
        if (!SampleBilinear(f.right, u, v, c, &r)) {
          inside = false;
          break;
        }
        ok &= std::abs(r - f.left.ptr<uint8_t>(y)[x * C + c]) <= tolerance;
      }
      if (!inside) continue;
      ++stats.visible;
      stats.consistent += ok;
    }
  }
  return stats;
}

}  // namespace epmap::sim::testing
