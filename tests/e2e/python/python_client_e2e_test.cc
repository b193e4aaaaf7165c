// The Python planner example (grpcio) against a real epmapd fed by epmap-replay over DDS, and
// on a mobile base fed by epmap-sim.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/dataset/dataset.h"
#include "tests/support/building_run.h"
#include "tests/support/epmapd_fixture.h"

namespace epmap {
namespace {

// clients/python/epmap_planner.py against epmapd, with the stubs the build generated.
std::pair<int, std::string> RunPlanner(testing::Epmapd& epmapd, const std::filesystem::path& work,
                                       const std::vector<std::string>& extra = {}) {
  const auto script = testing::SourceDir() / "clients/python/epmap_planner.py";
  const auto stubs = testing::BinDir().parent_path() / "python";
  std::vector<std::string> args = {script.string(), "--server", epmapd.address(), "--stubs",
                                   stubs.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  return testing::RunToCompletion("/usr/bin/python3", args, work / "python.log",
                                  std::chrono::seconds(60));
}

TEST(PythonClientE2E, PlannerExampleReadsDepthAhead) {
  if (!std::filesystem::exists("/usr/bin/python3")) GTEST_SKIP() << "no /usr/bin/python3";
  EPMAP_REQUIRE_SHARED_DATA("stereo-pairs/cones");
  const auto work = testing::FreshTempDir("python");
  const uint32_t domain = testing::UniqueDomainId(303);
  testing::Epmapd epmapd(domain, {}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();
  const auto [replay_code, replay_out] =
      testing::RunToCompletion(testing::BinDir() / "epmap-replay",
                               {(testing::SharedDataDir() / "stereo-pairs/cones").string(),
                                "--domain", std::to_string(domain)},
                               work / "replay.log", std::chrono::seconds(60));
  ASSERT_EQ(replay_code, 0) << replay_out;

  const auto [code, out] = RunPlanner(epmapd, work);
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("\"frames_processed\": 1"), std::string::npos) << out;
  EXPECT_NE(out.find("\"width\": 450"), std::string::npos) << out;
  EXPECT_NE(out.find("\"depth_ahead_median_m\": "), std::string::npos) << out;
  EXPECT_EQ(out.find("\"depth_ahead_median_m\": null"), std::string::npos) << out;
  // A single still pair: expected perception has compared nothing, so nothing moved.
  EXPECT_NE(out.find("\"moving_on_its_own\": []"), std::string::npos) << out;
  std::filesystem::remove_all(work);
}

// Distance from p along direction d (unit) to the first wall segment it meets.
double RayToWalls(const Eigen::Vector2d& p, const Eigen::Vector2d& d,
                  const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& walls) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& [a, b] : walls) {
    const Eigen::Vector2d e = b - a;
    const double denom = d.x() * e.y() - d.y() * e.x();
    if (std::abs(denom) < 1e-12) continue;
    const Eigen::Vector2d w = a - p;
    const double t = (w.x() * e.y() - w.y() * e.x()) / denom;  // along the ray
    const double u = (w.x() * d.y() - w.y() * d.x()) / denom;  // along the wall
    if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
  }
  return best;
}

// A remote planner on a mobile base: the corrected pose and the grid, and how far the grid is
// free ahead, which must never reach past a true wall.
TEST(PythonClientE2E, PlannerExampleReadsTheGridAheadOfAMobileBase) {
  if (!std::filesystem::exists("/usr/bin/python3")) GTEST_SKIP() << "no /usr/bin/python3";
  const auto work = testing::FreshTempDir("python-base");
  const uint32_t domain = testing::UniqueDomainId(304);
  constexpr int kFrames = 150;  // out of the start room, facing the corridor through its door
  dataset::Dataset data;
  ASSERT_NO_FATAL_FAILURE(testing::RecordBuilding(work, kFrames, &data));
  testing::Epmapd epmapd(domain, {"--urdf", data.urdf->string()}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();
  v1::ServiceStatus idle;
  ASSERT_NO_FATAL_FAILURE(testing::PublishBuildingUntilIdle(epmapd, domain, work, kFrames, &idle));

  const auto [code, out] = RunPlanner(epmapd, work);
  ASSERT_EQ(code, 0) << out;
  const YAML::Node j = YAML::Load(out);
  EXPECT_EQ(j["mode"].as<std::string>(), "mobile-base") << out;
  const YAML::Node map = j["map"];
  ASSERT_TRUE(map && map["free_ahead_m"]) << out;

  // The same grid as the C++ API serves.
  grpc::ClientContext context;
  v1::OccupancyGrid grid;
  ASSERT_TRUE(epmapd.stub().GetOccupancyGrid(&context, {}, &grid).ok());
  EXPECT_EQ(map["width"].as<uint32_t>(), grid.width());
  EXPECT_EQ(map["height"].as<uint32_t>(), grid.height());
  size_t occupied = 0;
  for (const char c : grid.occupancy()) {
    const auto v = static_cast<uint8_t>(c);
    occupied += v != 255 && v > 65;
  }
  EXPECT_EQ(map["occupied_cells"].as<size_t>(), occupied);
  EXPECT_GT(occupied, 20u);

  // The true walls in the maps' world frame (the start pose = the odometry frame), and the
  // ray from the corrected pose (centimetres from the truth here: MapsE2E) along its heading.
  Eigen::Isometry2d T_maps_gt;
  ASSERT_NO_FATAL_FAILURE(testing::GroundTruthToMaps(data, &T_maps_gt));
  const auto walls = testing::WallsInMaps(data, T_maps_gt);
  const auto pose = map["pose_corrected"];
  const Eigen::Vector2d at(pose[0].as<double>(), pose[1].as<double>());
  const double heading = pose[2].as<double>();
  const double to_wall = RayToWalls(at, {std::cos(heading), std::sin(heading)}, walls);
  const double free_ahead = map["free_ahead_m"].as<double>();
  std::printf("free ahead %.2f m (%s), the true wall %.2f m ahead\n", free_ahead,
              map["free_ahead_ends"].as<std::string>().c_str(), to_wall);
  ASSERT_TRUE(std::isfinite(to_wall));
  EXPECT_LE(free_ahead, to_wall + 0.3) << out;  // never free through a wall
  // The robot faces its room's door 1.2 m ahead, the corridor beyond it: the grid must see
  // through the door. (Measured: it ends 3.3 m ahead, at uncertain cells in the far corridor
  // wall's door; the first true wall on the ray is in the room beyond, 16.7 m ahead.)
  EXPECT_GE(free_ahead, 1.5) << out;
  EXPECT_EQ(map["combined_layers"].as<uint32_t>(), grid.combined_layers());

  // The perceptual map's segments in the 8 m square around the robot: the service's window of
  // it, and its nearest segment no farther than the nearest true wall (a wall or furniture
  // in front of it; the robot has panned around its room).
  const YAML::Node near = map["walls_near"];
  ASSERT_TRUE(near && near["segments"]) << out;
  {
    grpc::ClientContext pmap_context;
    v1::GetPerceptualMapRequest request;
    request.set_around_robot_m(8.0);
    v1::PerceptualMap window;
    ASSERT_TRUE(epmapd.stub().GetPerceptualMap(&pmap_context, request, &window).ok());
    EXPECT_EQ(near["segments"].as<int>(), window.segments_size()) << out;
    EXPECT_EQ(near["segments_in_map"].as<uint32_t>(), window.segments_in_map()) << out;
  }
  ASSERT_GT(near["segments"].as<int>(), 0) << out;
  double to_nearest_wall = std::numeric_limits<double>::infinity();
  for (const auto& [a, b] : walls) {
    const Eigen::Vector2d d = b - a;
    const double t = std::clamp((at - a).dot(d) / std::max(d.squaredNorm(), 1e-12), 0.0, 1.0);
    to_nearest_wall = std::min(to_nearest_wall, (at - (a + t * d)).norm());
  }
  const double nearest = near["nearest_m"].as<double>();
  std::printf(
      "perceptual map: %d of %u segments in the 8 m window, the nearest %.2f m away "
      "(the nearest true wall %.2f m)\n",
      near["segments"].as<int>(), near["segments_in_map"].as<uint32_t>(), nearest, to_nearest_wall);
  EXPECT_LE(nearest, to_nearest_wall + 0.3) << out;

  // A robot 0.5 m tall plans on the lowest band alone (0.10-0.70 m): the service's grid over
  // that band, and still never free through a wall.
  const auto [low_code, low_out] = RunPlanner(epmapd, work, {"--robot-height", "0.5"});
  ASSERT_EQ(low_code, 0) << low_out;
  const YAML::Node low = YAML::Load(low_out)["map"];
  ASSERT_TRUE(low && low["free_ahead_m"]) << low_out;
  EXPECT_EQ(low["combined_layers"].as<uint32_t>(), 1u) << low_out;
  EXPECT_NEAR(low["bands_m"][1].as<double>(), 0.7, 1e-9) << low_out;
  grpc::ClientContext low_context;
  v1::GetOccupancyGridRequest low_request;
  low_request.set_max_height_m(0.5);
  v1::OccupancyGrid low_grid;
  ASSERT_TRUE(epmapd.stub().GetOccupancyGrid(&low_context, low_request, &low_grid).ok());
  EXPECT_EQ(low["width"].as<uint32_t>(), low_grid.width());
  EXPECT_EQ(low["height"].as<uint32_t>(), low_grid.height());
  const double low_free = low["free_ahead_m"].as<double>();
  std::printf("robot 0.5 m tall: free ahead %.2f m (%s)\n", low_free,
              low["free_ahead_ends"].as<std::string>().c_str());
  EXPECT_LE(low_free, to_wall + 0.3) << low_out;
  // A local planner's window, 4 m around the robot: the service's window, and free ahead as far
  // as the whole map says or to the window's edge, 2 m ahead (a cell either way).
  const auto [window_code, window_out] = RunPlanner(epmapd, work, {"--around-robot", "4"});
  ASSERT_EQ(window_code, 0) << window_out;
  const YAML::Node window = YAML::Load(window_out)["map"];
  ASSERT_TRUE(window && window["free_ahead_m"]) << window_out;
  EXPECT_TRUE(window["window"].as<bool>()) << window_out;
  EXPECT_FALSE(map["window"].as<bool>()) << out;
  EXPECT_GE(window["width"].as<uint32_t>(), 40u) << window_out;
  EXPECT_LE(window["width"].as<uint32_t>(), 41u) << window_out;
  const double window_free = window["free_ahead_m"].as<double>();
  std::printf("4 m window around the robot: free ahead %.2f m (%s)\n", window_free,
              window["free_ahead_ends"].as<std::string>().c_str());
  EXPECT_LE(window_free, free_ahead + 1e-6) << window_out;
  EXPECT_GE(window_free, std::min(free_ahead, 1.9)) << window_out;
  const auto [bad_code, bad_out] = RunPlanner(epmapd, work, {"--robot-height", "0.05"});
  EXPECT_NE(bad_code, 0);
  EXPECT_NE(bad_out.find("INVALID_ARGUMENT"), std::string::npos) << bad_out;
  if (!HasFailure()) std::filesystem::remove_all(work);
}

}  // namespace
}  // namespace epmap
