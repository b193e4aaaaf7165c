// Scenario `eye-hand` (paper 001, Sec. III-B and IV-A): the end effector follows ellipsoidal
// paths in the reach workspace while the stereo head watches it. Each sample pairs X_B, where
// the kinematics puts the fingertip, with X_A, where stereo vision sees it, both in the ROOT
// frame (base_link of urdf/icub_head.urdf: x forward, y left, z up, at the neck's pivot).
//
// Paths: 20 ellipsoids with random centres, sizes and orientations; each is sampled by two
// ellipses on orthogonal planes through its centre, 50 points each: 100 points per path and
// 2000 in all, as in the paper. One sample every 0.5 s, 10 s between paths.
//
// Vision differs from kinematics by a smooth, workspace-dependent error of about 4 cm on
// average (the paper's figure for the iCub) that no single rigid transform removes:
//   X_A = E + (1 + s) R0 (X_B - E) + t0 + sag(X_B) + regional(X_B) + noise
// with E the eyes' centre, s a 1% stereo depth-scale error (a miscalibrated baseline), R0 and
// t0 a rigid offset (2 degrees, 5 cm), sag a gravity-like droop growing with the squared
// distance from the shoulder, regional offsets blended across the workspace (ErrorModel), and
// 1.5 mm Gaussian noise per axis (scaled by --encoder-noise-scale; none with --no-noise).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "clients/sim/random.h"
#include "clients/sim/scenario_factories.h"
#include "clients/sim/urdf_model.h"

namespace epmap::sim {

namespace {

constexpr int kPaths = 20;
constexpr int kPointsPerEllipse = 50;  // two ellipses per path: 100 points
constexpr double kSamplePeriodS = 0.5;
constexpr double kPathGapS = 10.0;
constexpr double kNoiseM = 0.0015;

// Reach workspace of the right arm in ROOT (ellipsoid centres are drawn inside it).
const Eigen::Vector3d kWorkspaceLo(0.18, -0.42, -0.34), kWorkspaceHi(0.38, 0.16, -0.14);
const Eigen::Vector3d kEyes(0.06, 0.0, 0.12);        // where stereo measures depth from
const Eigen::Vector3d kShoulder(0.0, -0.16, -0.12);  // where the arm's sag grows from

// The vision-kinematics error: a rigid part, a stereo depth-scale error, a gravity-like sag,
// and regional offsets that differ across the workspace (the arm reaches different zones with
// different joint configurations, whose unmodelled play and elasticity differ). The regional
// part is a smooth blend of four small rigid motions about anchor points, so that no single
// rigid transform removes it while a few local ones largely do.
struct ErrorModel {
  struct Region {
    Eigen::Vector3d anchor;
    Eigen::Matrix3d R;  // small rotation about the anchor
    Eigen::Vector3d t;
  };
  double depth_scale = 0.01;
  Eigen::Matrix3d R0 = Rotation(2.0, {0.3, 0.8, 0.5});
  Eigen::Vector3d t0 = Eigen::Vector3d(0.034, -0.024, 0.028);
  double sag_per_m2 = 0.08;  // metres of droop per squared metre of reach
  // Regions along the workspace's long (lateral) axis, blended by normalised Gaussians.
  double region_width = 0.10;  // metres
  std::vector<Region> regions = {
      {{0.28, -0.34, -0.24}, Rotation(1.25, {1, 0.2, -0.3}), {0.020, 0.015, -0.0125}},
      {{0.28, -0.20, -0.24}, Rotation(1.25, {-0.4, 1, 0.3}), {-0.015, 0.019, 0.0125}},
      {{0.28, -0.06, -0.24}, Rotation(1.25, {0.2, -0.5, 1}), {-0.015, -0.0175, -0.014}},
      {{0.28, 0.08, -0.24}, Rotation(1.25, {0.7, 0.7, 0}), {0.015, -0.015, 0.020}},
  };

  static Eigen::Matrix3d Rotation(double degrees, const Eigen::Vector3d& axis) {
    return Eigen::AngleAxisd(degrees * std::numbers::pi / 180, axis.normalized())
        .toRotationMatrix();
  }

  Eigen::Vector3d Vision(const Eigen::Vector3d& xb) const {
    Eigen::Vector3d xa = kEyes + (1 + depth_scale) * (R0 * (xb - kEyes)) + t0;
    const double r2 = (xb - kShoulder).squaredNorm();
    xa += Eigen::Vector3d(0.3 * sag_per_m2 * r2, 0.0, -sag_per_m2 * r2);
    double weight_sum = 0;
    Eigen::Vector3d regional = Eigen::Vector3d::Zero();
    for (const Region& r : regions) {
      const double w = std::exp(-(xb - r.anchor).squaredNorm() / (2 * region_width * region_width));
      regional += w * ((r.R - Eigen::Matrix3d::Identity()) * (xb - r.anchor) + r.t);
      weight_sum += w;
    }
    return xa + regional / std::max(weight_sum, 1e-12);
  }
};

class EyeHandScenario final : public Scenario {
 public:
  explicit EyeHandScenario(const ScenarioOptions& options) : Scenario(options) {
    Rng rng(options.seed, Stream::kEyeHand);
    const ErrorModel model;
    const double sigma = options.noise ? kNoiseM * options.encoder_noise_scale : 0.0;
    double t = 0;
    for (int p = 0; p < kPaths; ++p) {
      const Eigen::Vector3d radii(rng.Uniform(0.04, 0.08), rng.Uniform(0.03, 0.07),
                                  rng.Uniform(0.02, 0.06));
      Eigen::Vector3d centre;
      for (int k = 0; k < 3; ++k) {
        centre[k] = rng.Uniform(kWorkspaceLo[k] + 0.04, kWorkspaceHi[k] - 0.04);
      }
      const Eigen::Quaterniond q(rng.Gaussian(), rng.Gaussian(), rng.Gaussian(), rng.Gaussian());
      const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
      char label[8];
      std::snprintf(label, sizeof(label), "e%02d", p);
      for (int e = 0; e < 2; ++e) {
        for (int k = 0; k < kPointsPerEllipse; ++k) {
          const double a = 2 * std::numbers::pi * k / kPointsPerEllipse;
          // First ellipse in the plane of axes 1-2, second in the plane of axes 1-3.
          const Eigen::Vector3d local =
              e == 0 ? Eigen::Vector3d(radii[0] * std::cos(a), radii[1] * std::sin(a), 0)
                     : Eigen::Vector3d(radii[0] * std::cos(a), 0, radii[2] * std::sin(a));
          EyeHandSample s;
          s.stamp_ns = options.start_stamp_ns + std::llround(t * 1e9);
          s.xb = centre + R * local;
          s.xa_noise_free = model.Vision(s.xb);
          s.xa = s.xa_noise_free +
                 sigma * Eigen::Vector3d(rng.Gaussian(), rng.Gaussian(), rng.Gaussian());
          s.path = label;
          samples_.push_back(s);
          t += kSamplePeriodS;
        }
      }
      t += kPathGapS;
    }
  }

  int frame_count() const override { return 0; }
  double rate_hz() const override { return 1.0 / kSamplePeriodS; }
  bool rectified() const override { return false; }
  dataset::CameraSensor cam0() const override { return {}; }
  dataset::CameraSensor cam1() const override { return {}; }
  std::string urdf() const override { return IcubHeadUrdf(); }
  std::string true_urdf() const override { return IcubHeadUrdf(); }
  std::vector<std::string> joint_names() const override { return {}; }
  SimFrame RenderFrame(int index, bool ground_truth) const override {
    CheckIndex(index);  // throws: no images
    (void)ground_truth;
    return {};
  }
  std::vector<EyeHandSample> EyeHandSamples() const override { return samples_; }
  std::string Describe() const override {
    return "eye-hand: " + std::to_string(samples_.size()) + " samples on " +
           std::to_string(kPaths) + " ellipsoidal paths, seed " + std::to_string(options().seed);
  }

 private:
  std::vector<EyeHandSample> samples_;
};

}  // namespace

std::unique_ptr<Scenario> MakeEyeHandScenario(const ScenarioOptions& options) {
  return std::make_unique<EyeHandScenario>(options);
}

}  // namespace epmap::sim
