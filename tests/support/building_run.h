#pragma once
// A short run of the synthetic building robot for end-to-end tests: recorded once (its URDF
// for epmapd, its ground truth for the checks), then published over DDS with the same seed to a
// real epmapd, and the true walls brought into the frame the service's maps are in.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "common/dataset/dataset.h"
#include "tests/support/epmapd_fixture.h"

namespace epmap::testing {

inline Eigen::Isometry2d PlanarPose(double x, double y, double theta) {
  return Eigen::Translation2d(x, y) * Eigen::Rotation2Dd(theta);
}

// epmap-sim record --scenario building --frames N into work/rec. Use with
// ASSERT_NO_FATAL_FAILURE.
inline void RecordBuilding(const std::filesystem::path& work, int frames, dataset::Dataset* out) {
  const auto rec = work / "rec";
  const auto [code, output] = RunToCompletion(BinDir() / "epmap-sim",
                                              {"record", "--scenario", "building", "--frames",
                                               std::to_string(frames), "--out", rec.string()},
                                              work / "record.log", std::chrono::seconds(60));
  ASSERT_EQ(code, 0) << output;
  *out = dataset::Load(rec);
  ASSERT_TRUE(out->urdf.has_value());
  ASSERT_FALSE(out->walls.empty());
  ASSERT_FALSE(out->odometry.empty());
}

// epmap-sim publish --scenario building --frames N on epmapd's domain, then waits until the
// queue has drained and the pipeline is idle; *idle is the status then. Use with
// ASSERT_NO_FATAL_FAILURE.
inline void PublishBuildingUntilIdle(Epmapd& epmapd, uint32_t domain,
                                     const std::filesystem::path& work, int frames,
                                     v1::ServiceStatus* idle) {
  const auto [code, output] =
      RunToCompletion(BinDir() / "epmap-sim",
                      {"publish", "--scenario", "building", "--frames", std::to_string(frames),
                       "--domain", std::to_string(domain)},
                      work / "publish.log", std::chrono::seconds(90));
  ASSERT_EQ(code, 0) << output;
  uint64_t last = ~0ull;
  *idle = epmapd.WaitStatus(
      [&](const v1::ServiceStatus& s) {
        const bool still = s.queue_depth() == 0 && s.frames_processed() == last;
        last = s.frames_processed();
        return still;
      },
      std::chrono::seconds(30));
}

// The ground truth's world in the maps' world frame (the start pose = the odometry frame):
// T such that T * (true pose) is where the maps should put the base. Use with
// ASSERT_NO_FATAL_FAILURE.
inline void GroundTruthToMaps(const dataset::Dataset& data, Eigen::Isometry2d* T_maps_gt) {
  const auto gt0 = dataset::InterpolatePlanar(data.gt_base_pose, data.odometry.front().stamp_ns);
  ASSERT_TRUE(gt0.has_value());
  const auto& o0 = data.odometry.front();
  *T_maps_gt = (PlanarPose(gt0->x, gt0->y, gt0->theta) * PlanarPose(o0.x, o0.y, o0.theta).inverse())
                   .inverse();
}

// The true walls' faces (walls.csv) in the maps' world frame.
inline std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> WallsInMaps(
    const dataset::Dataset& data, const Eigen::Isometry2d& T_maps_gt) {
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> walls;
  for (const auto& w : data.walls) {
    walls.emplace_back(T_maps_gt * Eigen::Vector2d(w.x1, w.y1),
                       T_maps_gt * Eigen::Vector2d(w.x2, w.y2));
  }
  return walls;
}

}  // namespace epmap::testing
