// maps-test-world --world room|building --out DIR [--reverse]: writes a synthetic mobile-base
// run (tests/support/planar_world.h) in the dataset layout, for the maps integration test and
// for trying `epmap-bench maps` before a full simulator is at hand. "building" is a ring
// corridor of about 60 m inside a 28 m x 28.5 m floor with rooms around it.

#include <CLI/CLI.hpp>
#include <iostream>

#include "tests/support/planar_world.h"

namespace {

using epmap::testing::Wall;

std::vector<Wall> BuildingWalls() {
  std::vector<Wall> w;
  const auto add = [&](double x1, double y1, double x2, double y2, double h = 2.4) {
    w.push_back({{x1, y1}, {x2, y2}, h});
  };
  // Outer shell 28 x 28.5.
  add(0, 0, 28, 0);
  add(28, 0, 28, 28.5);
  add(28, 28.5, 0, 28.5);
  add(0, 28.5, 0, 0);
  // Outer corridor walls (5,5)-(23,21) with door gaps.
  add(5, 5, 11, 5);
  add(12, 5, 23, 5);
  add(23, 5, 23, 12);
  add(23, 13, 23, 21);
  add(23, 21, 16, 21);
  add(15, 21, 5, 21);
  add(5, 21, 5, 15);
  add(5, 14, 5, 5);
  // Inner block (7,7)-(21,19), split into two rooms, doors to the corridor.
  add(7, 7, 13, 7);
  add(14, 7, 21, 7);
  add(21, 7, 21, 19);
  add(21, 19, 9, 19);
  add(8, 19, 7, 19);
  add(7, 19, 7, 7);
  add(14, 7, 14, 19);
  // Room partitions between the corridor and the shell.
  add(0, 14, 5, 14);
  add(23, 10, 28, 10);
  add(11, 21, 11, 28.5);
  add(18, 0, 18, 5);
  // Low furniture in the corridor's wide corners (a cabinet and a bench).
  add(21.6, 5.4, 22.6, 5.4, 0.9);
  add(5.4, 20.6, 6.4, 20.6, 0.5);
  return w;
}

int Main(int argc, char** argv) {
  CLI::App app("writes a synthetic mobile-base dataset for the maps tests");
  std::string world = "room", out;
  bool reverse = false;
  app.add_option("--world", world, "room | building");
  app.add_option("--out", out, "output folder")->required();
  app.add_flag("--reverse", reverse, "drive the loop the other way round");
  CLI11_PARSE(app, argc, argv);
  std::vector<Eigen::Vector2d> waypoints;
  std::vector<Wall> walls;
  if (world == "room") {
    walls = epmap::testing::RoomWalls();
    waypoints = {{1.2, 1.2}, {6.8, 1.2}, {6.8, 4.8}, {1.2, 4.8}, {1.2, 2.5}};
  } else if (world == "building") {
    walls = BuildingWalls();
    waypoints = {{6, 13}, {6, 6}, {22, 6}, {22, 20}, {6, 20}, {6, 13.5}};
  } else {
    std::cerr << "unknown world '" << world << "'\n";
    return 2;
  }
  if (reverse) {
    std::reverse(waypoints.begin() + 1, waypoints.end() - 1);
  }
  const Eigen::Vector2d d = waypoints[1] - waypoints[0];
  epmap::testing::RunParams rp;
  if (world == "building") {
    rp.heading_scale_error = 0.035;
    rp.heading_drift_per_m = 0.0015;
  }
  const auto run = epmap::testing::SimulateRun(waypoints, std::atan2(d.y(), d.x()), rp);
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
