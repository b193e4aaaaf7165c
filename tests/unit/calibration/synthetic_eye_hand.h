#pragma once
// Synthetic eye-hand data for the unit tests (the real scenario comes from clients/sim): the
// kinematic points X_B follow the paper's acquisition (each path = two ellipses on orthogonal
// planes, 100 points), and the vision points are X_A = R(x) X_B + t(x) + noise, a smooth,
// curved, workspace-dependent error of a few centimetres that one rigid map cannot absorb.

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "perception/calibration/eye_hand_samples.h"

namespace epmap::calibration::testing {

struct SyntheticEyeHandParams {
  int paths = 20;
  int points_per_path = 100;
  double noise_m = 0.002;  // per axis
  double curvature = 1.0;  // scales the non-rigid part of the error field
  uint64_t seed = 11;
};

// The error field X_B -> X_A: a rigid offset plus a smooth non-rigid part.
inline Eigen::Vector3d DistortedVision(const Eigen::Vector3d& xb, double curvature) {
  const Eigen::Vector3d centre(-0.30, 0.0, 0.10);
  const Eigen::Vector3d d = xb - centre;
  // Rigid part: ~2.5 deg about a tilted axis and a 3 cm offset.
  const Eigen::Matrix3d r0 =
      Eigen::AngleAxisd(0.045, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
  const Eigen::Vector3d t0(0.025, -0.02, 0.015);
  // Non-rigid part: a rotation that varies across the workspace (elastic links) and a
  // quadratic sag, together ~1-2 cm at the edges of the workspace.
  const Eigen::Vector3d w = curvature * Eigen::Vector3d(0.6 * d.y(), -0.5 * d.z(), 0.7 * d.x());
  const Eigen::Matrix3d rv = w.norm() > 0
                                 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                                 : Eigen::Matrix3d::Identity();
  const Eigen::Vector3d sag = curvature * Eigen::Vector3d(0.5 * d.y() * d.y(), 0.6 * d.x() * d.z(),
                                                          -0.8 * (d.x() * d.x() + d.y() * d.y()));
  return r0 * (centre + rv * d) + t0 + sag;
}

inline std::vector<EyeHandSample> MakeEyeHandSamples(const SyntheticEyeHandParams& p) {
  std::mt19937_64 rng(p.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, p.noise_m);
  std::vector<EyeHandSample> out;
  int64_t stamp = 1'000'000'000;
  for (int k = 0; k < p.paths; ++k) {
    const Eigen::Vector3d c(-0.40 + 0.20 * u(rng), -0.20 + 0.40 * u(rng), 0.00 + 0.25 * u(rng));
    const Eigen::Vector3d rv(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5);
    const Eigen::Matrix3d rot =
        Eigen::AngleAxisd(3.0 * rv.norm(), rv.normalized()).toRotationMatrix();
    const double a = 0.04 + 0.06 * u(rng), b = 0.03 + 0.05 * u(rng), c2 = 0.03 + 0.05 * u(rng);
    char name[16];
    std::snprintf(name, sizeof name, "p%02d", k);
    for (int i = 0; i < p.points_per_path; ++i) {
      const bool first = i < p.points_per_path / 2;
      const int half = p.points_per_path / 2;
      const double phi = 2.0 * M_PI * (first ? i : i - half) / half;
      // Two ellipses on orthogonal planes (u-v and u-w) through the same centre.
      const Eigen::Vector3d local = first
                                        ? Eigen::Vector3d(a * std::cos(phi), b * std::sin(phi), 0)
                                        : Eigen::Vector3d(a * std::cos(phi), 0, c2 * std::sin(phi));
      EyeHandSample s;
      s.stamp_ns = stamp;
      stamp += 50'000'000;
      s.xb = c + rot * local;
      s.xa =
          DistortedVision(s.xb, p.curvature) + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      s.path = name;
      out.push_back(s);
    }
  }
  return out;
}

}  // namespace epmap::calibration::testing
