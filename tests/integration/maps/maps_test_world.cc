// maps-test-world --world room|building --out DIR [--reverse]: writes a synthetic mobile-base
// run (tests/support/planar_world.h) in the dataset layout, for the maps integration test and
// for trying `epmap-bench maps` before a full simulator is at hand. "building" is a 28 m x
// 28.5 m floor (a corridor, five rooms, furniture) and a loop of about 65 m through it.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "tests/support/planar_world.h"

namespace {

using epmap::testing::Wall;

// The whole building is shifted off the 10 cm lattice of the grid (walls at round numbers
// would all lie on cell boundaries, a case real walls rarely line up with).
const Eigen::Vector2d kBuildingShift(0.037, 0.043);

std::vector<Wall> BuildingWalls() {
  std::vector<Wall> w;
  const auto add = [&](double x1, double y1, double x2, double y2, double h = 2.4) {
    w.push_back(
        {Eigen::Vector2d(x1, y1) + kBuildingShift, Eigen::Vector2d(x2, y2) + kBuildingShift, h});
  };
  // Shell 28 x 28.5.
  add(0, 0, 28, 0);
  add(28, 0, 28, 28.5);
  add(28, 28.5, 0, 28.5);
  add(0, 28.5, 0, 0);
  // East-west corridor, y in [12.5, 15], doors into the rooms on both sides.
  add(0, 12.5, 5, 12.5);
  add(6, 12.5, 13, 12.5);
  add(14, 12.5, 17, 12.5);
  add(18, 12.5, 23, 12.5);
  add(24, 12.5, 28, 12.5);
  add(0, 15, 7, 15);
  add(8, 15, 20, 15);
  add(21, 15, 25, 15);
  add(26, 15, 28, 15);
  // Rooms south (x < 9, 9..19, > 19) and north (x < 14, > 14).
  add(9, 0, 9, 12.5);
  add(19, 0, 19, 12.5);
  add(14, 15, 14, 28.5);
  // Furniture: tables (0.75 m) and a cabinet (1.8 m) as boxes, a low bench in the corridor.
  const auto box = [&](double x, double y, double sx, double sy, double h) {
    add(x, y, x + sx, y, h);
    add(x + sx, y, x + sx, y + sy, h);
    add(x + sx, y + sy, x, y + sy, h);
    add(x, y + sy, x, y, h);
  };
  box(15.2, 3.0, 1.6, 0.8, 0.75);
  box(11.0, 9.5, 0.6, 1.4, 1.8);
  box(23.0, 20.5, 1.2, 1.2, 0.75);
  box(26.8, 16.0, 0.6, 2.0, 1.8);
  add(9.5, 14.6, 11.0, 14.6, 0.45);
  return w;
}

int Main(int argc, char** argv) {
  CLI::App app("writes a synthetic mobile-base dataset for the maps tests");
  std::string world = "room", out;
  bool reverse = false, odometry_only = false;
  app.add_option("--world", world, "room | building");
  app.add_option("--out", out, "output folder")->required();
  app.add_flag("--reverse", reverse, "drive the loop the other way round");
  app.add_flag("--odometry-only", odometry_only,
               "rewrite only odometry0/ of a dataset this tool wrote (same world and route)");
  CLI11_PARSE(app, argc, argv);
  std::vector<Eigen::Vector2d> waypoints;
  std::vector<Wall> walls;
  if (world == "room") {
    walls = epmap::testing::RoomWalls();
    waypoints = {{1.2, 1.2}, {6.8, 1.2}, {6.8, 4.8}, {1.2, 4.8}, {1.2, 2.5}};
  } else if (world == "building") {
    walls = BuildingWalls();
    // A loop of about 65 m: east along the corridor, through the middle south room (in by one
    // door, out by the other), into the east north room and out, back west along the corridor.
    waypoints = {{4, 13.8},    {13.5, 13.8}, {13.5, 8},  {17.5, 8},    {17.5, 13.8},
                 {20.5, 13.8}, {20.5, 19},   {25.5, 19}, {25.5, 13.8}, {4.5, 13.8}};
    for (auto& p : waypoints) p += kBuildingShift;
  } else {
    std::cerr << "unknown world '" << world << "'\n";
    return 2;
  }
  if (reverse) {
    // The same loop the other way round, from the same start and end (paper 003's protocol).
    std::reverse(waypoints.begin() + 1, waypoints.end() - 1);
  }
  const Eigen::Vector2d d = waypoints[1] - waypoints[0];
  epmap::testing::RunParams rp;
  if (world == "building") {
    // About 20 degrees of heading error at the end of the loop, as the planned simulator's.
    rp.heading_scale_error = 0.03;
    rp.heading_drift_per_m = 0.006;
  }
  const auto run = epmap::testing::SimulateRun(waypoints, std::atan2(d.y(), d.x()), rp);
  if (odometry_only) {
    const auto csv = std::filesystem::path(out) / "mav0" / "odometry0" / "data.csv";
    if (!std::filesystem::exists(csv)) {
      std::cerr << csv << " does not exist: write the dataset first\n";
      return 1;
    }
    std::ofstream o(csv);
    o << "#timestamp [ns],x [m],y [m],theta [rad]\n";
    char line[160];
    for (const auto& r : run) {
      std::snprintf(line, sizeof line, "%lld,%.6f,%.6f,%.6f\n", static_cast<long long>(r.stamp_ns),
                    r.odometry.x(), r.odometry.y(), r.odometry.z());
      o << line;
    }
    std::cout << "rewrote the odometry of " << run.size() << " frames in " << out << "\n";
    return 0;
  }
  const epmap::testing::PlanarWorld planar(walls);
  epmap::testing::WriteRunDataset(planar, run, out);
  std::cout << "wrote " << run.size() << " frames to " << out << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Main(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "maps-test-world: " << e.what() << "\n";
    return 1;
  }
}
