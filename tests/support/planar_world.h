#pragma once
// A small synthetic world for the map tests: textured vertical walls on a floor, seen by a
// rectified stereo camera on a pan unit of a differential-drive base, rendered by ray casting
// (2x2 supersampled so edges land at sub-pixel places). The run stops every metre or 45
// degrees of turn to pan; the odometry drifts in heading. Everything is deterministic.
//
// World frame: z up, floor at z = 0. Base frame: x forward, y left, z up, on the floor.
// Camera optical frame: x right, y down, z forward.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <numbers>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/dataset/dataset.h"
#include "common/dataset/writer.h"
#include "perception/stereo/rectification.h"

namespace epmap::testing {

inline uint32_t Hash(uint32_t a, uint32_t b = 0, uint32_t c = 0) {
  uint32_t h = a * 0x9E3779B1u ^ (b + 0x7F4A7C15u) * 0x85EBCA77u ^ (c + 0x165667B1u) * 0xC2B2AE3Du;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  h *= 0x297A2D39u;
  h ^= h >> 15;
  return h;
}
inline double Unit(uint32_t h) {
  return (h & 0xFFFFFF) / double(0x1000000);
}

struct Wall {
  Eigen::Vector2d a, b;
  double height = 2.4;
};

// Walls with a block texture: columns of random width along the wall, each cut at a few
// random heights, each block a random grey (vertical edges for stereo, corners for tracking).
class PlanarWorld {
 public:
  explicit PlanarWorld(std::vector<Wall> walls, uint32_t seed = 1) : walls_(std::move(walls)) {
    for (size_t w = 0; w < walls_.size(); ++w) {
      Texture t;
      const double len = (walls_[w].b - walls_[w].a).norm();
      double s = 0;
      uint32_t k = 0;
      while (s < len) {
        t.column_start.push_back(s);
        s += 0.12 + 0.35 * Unit(Hash(seed, static_cast<uint32_t>(w), k++));
      }
      t.column_start.push_back(std::numeric_limits<double>::infinity());
      textures_.push_back(std::move(t));
    }
  }
  const std::vector<Wall>& walls() const { return walls_; }
  double ceiling() const { return 2.6; }

  // Grey level seen along a ray from o in direction d (world frame); *t_hit (optional) gets
  // the ray parameter of the surface hit (distance in units of |d|).
  double Shade(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double* t_hit = nullptr) const {
    double best = std::numeric_limits<double>::infinity();
    double grey = 60;
    if (d.z() < -1e-9) {
      const double t = -o.z() / d.z();
      if (t < best) {
        best = t;
        grey = FloorGrey((o + t * d).head<2>());
      }
    } else if (d.z() > 1e-9) {
      const double t = (ceiling() - o.z()) / d.z();
      if (t < best) {
        best = t;
        grey = 205;
      }
    }
    for (size_t w = 0; w < walls_.size(); ++w) {
      const Eigen::Vector2d a = walls_[w].a, e = walls_[w].b - walls_[w].a;
      const double den = d.x() * (-e.y()) - d.y() * (-e.x());
      if (std::abs(den) < 1e-12) continue;
      const Eigen::Vector2d r = a - o.head<2>();
      const double t = (r.x() * (-e.y()) - r.y() * (-e.x())) / den;
      const double s = (d.x() * r.y() - d.y() * r.x()) / den;
      if (t <= 1e-6 || t >= best || s < 0 || s > 1) continue;
      const double z = o.z() + t * d.z();
      if (z < 0 || z > walls_[w].height) continue;
      best = t;
      grey = WallGrey(w, s * e.norm(), z);
    }
    if (t_hit) *t_hit = best;
    return grey;
  }

  // A rectified grey image of the camera at T_world_cam (optical frame). The camera must be
  // level (optical y straight down, as on a pan unit): then every image column looks along one
  // horizontal direction, so the walls are intersected once per sub-column. 8x2 samples per
  // pixel put vertical edges (the ones stereo uses) at an eighth of a pixel.
  cv::Mat Render(const Eigen::Isometry3d& T_world_cam, const stereo::RectifiedGeometry& cam,
                 uint32_t noise_seed) const {
    constexpr int kSx = 8, kSy = 2;
    const Eigen::Matrix3d R = T_world_cam.linear();
    if ((R.col(1) - Eigen::Vector3d(0, 0, -1)).norm() > 1e-9) {
      throw std::invalid_argument("PlanarWorld::Render: the camera must be level");
    }
    const Eigen::Vector3d o = T_world_cam.translation();
    const Eigen::Vector2d right = R.col(0).head<2>(), fwd = R.col(2).head<2>();
    cv::Mat sum(cam.height, cam.width, CV_64FC1, cv::Scalar(0));
    struct Hit {
      double t;
      size_t wall;
      double along;
    };
    std::vector<Hit> hits;
    for (int u = 0; u < cam.width; ++u) {
      for (int su = 0; su < kSx; ++su) {
        const double xn = (u + (su + 0.5) / kSx - 0.5 - cam.cx) / cam.fx;
        const Eigen::Vector2d h = xn * right + fwd;
        hits.clear();
        for (size_t w = 0; w < walls_.size(); ++w) {
          const Eigen::Vector2d a = walls_[w].a, e = walls_[w].b - walls_[w].a;
          const double den = h.x() * (-e.y()) - h.y() * (-e.x());
          if (std::abs(den) < 1e-12) continue;
          const Eigen::Vector2d r = a - o.head<2>();
          const double t = (r.x() * (-e.y()) - r.y() * (-e.x())) / den;
          const double s = (h.x() * r.y() - h.y() * r.x()) / den;
          if (t <= 1e-6 || s < 0 || s > 1) continue;
          hits.push_back({t, w, s * e.norm()});
        }
        std::sort(hits.begin(), hits.end(), [](const Hit& x, const Hit& y) { return x.t < y.t; });
        for (int v = 0; v < cam.height; ++v) {
          double acc = 0;
          for (int sv = 0; sv < kSy; ++sv) {
            const double yn = (v + (sv + 0.5) / kSy - 0.5 - cam.cy) / cam.fy;
            const double dz = -yn;
            double grey = 60;
            double best = std::numeric_limits<double>::infinity();
            if (dz < -1e-12) {
              best = -o.z() / dz;
              const Eigen::Vector2d p = o.head<2>() + best * h;
              grey = FloorGrey(p);
            } else if (dz > 1e-12) {
              best = (ceiling() - o.z()) / dz;
              grey = 205;
            }
            for (const auto& hit : hits) {
              if (hit.t >= best) break;
              const double z = o.z() + hit.t * dz;
              if (z < 0 || z > walls_[hit.wall].height) continue;
              grey = WallGrey(hit.wall, hit.along, z);
              break;
            }
            acc += grey;
          }
          sum.at<double>(v, u) += acc;
        }
      }
    }
    cv::Mat img(cam.height, cam.width, CV_8UC1);
    for (int v = 0; v < cam.height; ++v) {
      for (int u = 0; u < cam.width; ++u) {
        const double noise =
            3.0 *
            (Unit(Hash(noise_seed, static_cast<uint32_t>(u), static_cast<uint32_t>(v))) - 0.5);
        img.at<uint8_t>(v, u) =
            cv::saturate_cast<uint8_t>(sum.at<double>(v, u) / (kSx * kSy) + noise);
      }
    }
    return img;
  }

  double FloorGrey(const Eigen::Vector2d& p) const {
    const int64_t i = static_cast<int64_t>(std::floor(p.x() / 0.6));
    const int64_t j = static_cast<int64_t>(std::floor(p.y() / 0.6));
    return 95 + 30 * Unit(Hash(static_cast<uint32_t>(i), static_cast<uint32_t>(j), 7));
  }

  double WallGrey(size_t w, double along, double z) const {
    const auto& cs = textures_[w].column_start;
    const size_t col =
        static_cast<size_t>(std::upper_bound(cs.begin(), cs.end(), along) - cs.begin()) - 1;
    const uint32_t hc = Hash(static_cast<uint32_t>(w), static_cast<uint32_t>(col), 3);
    const double cut1 = 0.3 + 0.8 * Unit(hc), cut2 = 1.2 + 0.9 * Unit(Hash(hc));
    const uint32_t band = z < cut1 ? 0 : (z < cut2 ? 1 : 2);
    return 35 + 190 * Unit(Hash(static_cast<uint32_t>(w), static_cast<uint32_t>(col), band + 11));
  }

 private:
  struct Texture {
    std::vector<double> column_start;
  };
  std::vector<Wall> walls_;
  std::vector<Texture> textures_;
};

// The rig of the planned building scenario: 320x240, f = 251.5 px, 12 cm baseline.
inline stereo::RectifiedGeometry BumblebeeLikeCamera() {
  stereo::RectifiedGeometry g;
  g.width = 320;
  g.height = 240;
  g.fx = g.fy = 251.48735;
  g.cx = 159.5;
  g.cy = 119.5;
  g.baseline_m = 0.119952;
  return g;
}

constexpr double kPanAxisX = 0.10;  // pan axis ahead of the base origin
constexpr double kCameraHeight = 1.0;
constexpr double kLensAhead = 0.05;  // lens ahead of the pan axis

// cam0 (left, optical) on the base for a pan angle, as the URDF below gives it.
inline Eigen::Isometry3d CameraOnBase(double pan) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double c = std::cos(pan), s = std::sin(pan);
  const Eigen::Vector3d fwd(c, s, 0), right(s, -c, 0), down(0, 0, -1);
  T.linear().col(0) = right;
  T.linear().col(1) = down;
  T.linear().col(2) = fwd;
  // Left camera half a baseline to the left of the pan axis.
  T.translation() = Eigen::Vector3d(kPanAxisX, 0, kCameraHeight) + kLensAhead * fwd -
                    0.5 * BumblebeeLikeCamera().baseline_m * right;
  return T;
}

inline std::string PanHeadUrdf(double pan_limit = 1.7) {
  const double b = BumblebeeLikeCamera().baseline_m;
  char buf[2048];
  std::snprintf(buf, sizeof buf, R"(<?xml version="1.0"?>
<robot name="pan_base">
  <link name="base_footprint"/><link name="pan_link"/><link name="cam0_optical"/><link name="cam1_optical"/>
  <joint name="pan" type="revolute">
    <parent link="base_footprint"/><child link="pan_link"/>
    <origin xyz="%.4f 0 %.4f" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="%.4f" upper="%.4f" effort="1" velocity="1"/>
  </joint>
  <joint name="cam0_joint" type="fixed">
    <parent link="pan_link"/><child link="cam0_optical"/>
    <origin xyz="%.4f %.6f 0" rpy="-1.5707963267948966 0 -1.5707963267948966"/>
  </joint>
  <joint name="cam1_joint" type="fixed">
    <parent link="pan_link"/><child link="cam1_optical"/>
    <origin xyz="%.4f %.6f 0" rpy="-1.5707963267948966 0 -1.5707963267948966"/>
  </joint>
</robot>)",
                kPanAxisX, kCameraHeight, -pan_limit, pan_limit, kLensAhead, 0.5 * b, kLensAhead,
                -0.5 * b);
  return buf;
}

struct RunSample {
  int64_t stamp_ns = 0;
  Eigen::Vector3d truth;     // x, y, theta in the world
  Eigen::Vector3d odometry;  // x, y, theta in the odometry (start) frame
  double pan = 0;
};

struct RunParams {
  double frame_rate_hz = 5.0;
  double speed_mps = 0.4;
  double turn_rate = 0.5;  // rad/s when turning in place
  double pan_rate = 1.2;   // rad/s
  std::vector<double> pan_stops = {0.0, 0.8, 1.5, 0.8, 0.0, -0.8, -1.5, -0.8, 0.0};
  double stop_every_m = 1.0;
  double stop_every_rad = 0.785;
  double heading_scale_error = 0.04;   // odometry turn = true turn * (1 + this)
  double heading_drift_per_m = 0.003;  // rad per metre driven
  double distance_scale_error = 0.01;
};

// Drives through the waypoints (turn in place towards the next one, then straight), stopping
// to pan at the start, every stop_every_m and after every stop_every_rad of turning.
inline std::vector<RunSample> SimulateRun(const std::vector<Eigen::Vector2d>& waypoints,
                                          double start_theta, const RunParams& p = {}) {
  std::vector<RunSample> out;
  const double dt = 1.0 / p.frame_rate_hz;
  Eigen::Vector3d truth(waypoints.front().x(), waypoints.front().y(), start_theta);
  Eigen::Vector3d odo(0, 0, 0);
  int64_t stamp = 1'000'000'000;
  double pan = 0;
  const auto emit = [&]() {
    out.push_back({stamp, truth, odo, pan});
    stamp += static_cast<int64_t>(dt * 1e9);
  };
  const auto move = [&](double ds, double dth) {
    // Truth moves on an arc approximated by the midpoint heading; odometry sees it with errors.
    truth.x() += ds * std::cos(truth.z() + dth / 2);
    truth.y() += ds * std::sin(truth.z() + dth / 2);
    truth.z() += dth;
    const double ods = ds * (1 + p.distance_scale_error);
    const double odth = dth * (1 + p.heading_scale_error) + p.heading_drift_per_m * std::abs(ds);
    odo.x() += ods * std::cos(odo.z() + odth / 2);
    odo.y() += ods * std::sin(odo.z() + odth / 2);
    odo.z() += odth;
  };
  const auto pan_stop = [&]() {
    emit();
    for (double target : p.pan_stops) {
      while (std::abs(target - pan) > 1e-9) {
        const double step = std::clamp(target - pan, -p.pan_rate * dt, p.pan_rate * dt);
        pan += step;
        emit();
      }
    }
  };
  pan_stop();
  double since_stop_m = 0, since_stop_rad = 0;
  for (size_t w = 1; w < waypoints.size(); ++w) {
    const Eigen::Vector2d d = waypoints[w] - truth.head<2>();
    double turn = std::remainder(std::atan2(d.y(), d.x()) - truth.z(), 2 * std::numbers::pi);
    while (std::abs(turn) > 1e-9) {
      const double step = std::clamp(turn, -p.turn_rate * dt, p.turn_rate * dt);
      move(0, step);
      turn -= step;
      since_stop_rad += std::abs(step);
      emit();
      if (since_stop_rad >= p.stop_every_rad - 1e-9) {
        pan_stop();
        since_stop_rad = 0;
      }
    }
    double left = (waypoints[w] - truth.head<2>()).norm();
    while (left > 1e-9) {
      const double step = std::min(left, p.speed_mps * dt);
      move(step, 0);
      left -= step;
      since_stop_m += step;
      emit();
      if (since_stop_m >= p.stop_every_m - 1e-9) {
        pan_stop();
        since_stop_m = 0;
      }
    }
  }
  pan_stop();
  return out;
}

inline Eigen::Isometry3d BaseInWorld(const Eigen::Vector3d& xytheta) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(xytheta.z(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(xytheta.x(), xytheta.y(), 0);
  return T;
}

// Writes a run in the dataset layout (rectified images, joints0 with "pan", odometry0,
// kinematics.urdf, gt_base_pose0, gt_camera_pose0, gt_map/walls.csv).
inline void WriteRunDataset(const PlanarWorld& world, const std::vector<RunSample>& run,
                            const std::filesystem::path& root) {
  const auto cam = BumblebeeLikeCamera();
  dataset::Writer w(root, true);
  dataset::CameraSensor s = dataset::RectifiedPinholeSensor(cam.width, cam.height, cam.fx, cam.fy,
                                                            cam.cx, cam.cy, CameraOnBase(0), 5);
  w.WriteCameraSensor(0, s, "left camera, rectified");
  Eigen::Isometry3d right = CameraOnBase(0);
  right.translation() += right.linear().col(0) * cam.baseline_m;
  s.T_BS = right.matrix();
  w.WriteCameraSensor(1, s, "right camera, rectified");
  w.WriteUrdf(PanHeadUrdf());
  w.SetJointNames({"pan"});
  std::vector<dataset::WallSegment> walls;
  for (const auto& wall : world.walls()) {
    walls.push_back({wall.a.x(), wall.a.y(), wall.b.x(), wall.b.y()});
  }
  w.WriteWalls(walls);
  for (size_t i = 0; i < run.size(); ++i) {
    const auto& r = run[i];
    const Eigen::Isometry3d T_world_cam = BaseInWorld(r.truth) * CameraOnBase(r.pan);
    Eigen::Isometry3d T_world_right = T_world_cam;
    T_world_right.translation() += T_world_cam.linear().col(0) * cam.baseline_m;
    const cv::Mat left = world.Render(T_world_cam, cam, static_cast<uint32_t>(2 * i));
    const cv::Mat rightimg = world.Render(T_world_right, cam, static_cast<uint32_t>(2 * i + 1));
    w.AddStereoFrame(r.stamp_ns, left, rightimg);
    w.AddJoints(r.stamp_ns, {r.pan});
    w.AddOdometry({r.stamp_ns, r.odometry.x(), r.odometry.y(), r.odometry.z()});
    w.AddGtBasePose({r.stamp_ns, r.truth.x(), r.truth.y(), r.truth.z()});
    w.AddGtCameraPose(r.stamp_ns, T_world_cam);
  }
}

// A rectangular room with a few inner walls: small enough to render quickly.
inline std::vector<Wall> RoomWalls(double w = 8.0, double h = 6.0) {
  return {{{0, 0}, {w, 0}},        {{w, 0}, {w, h}},         {{w, h}, {0, h}},
          {{0, h}, {0, 0}},        {{2.5, 2.0}, {5.5, 2.0}}, {{5.5, 2.0}, {5.5, 4.0}},
          {{2.5, 4.0}, {4.0, 4.0}}};
}

}  // namespace epmap::testing
