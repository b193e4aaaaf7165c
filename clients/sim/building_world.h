#pragma once
// The office floor of scenario `building` (papers 002 and 003: a mobile robot with a panning
// stereo head wandering through corridors and rooms). Everything here is in the floor frame F:
// x east, y north, z up, the floor at z = 0, the building's south-west corner at the origin.
// The floor measures 28 m x 28.5 m: two crossing corridors 2.5 m wide and eight rooms with
// doors, painted walls (some plain), skirting boards, door frames, posters, desks, chairs,
// cabinets, bookshelves and plants.

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "clients/sim/renderer.h"
#include "clients/sim/scene_builder.h"
#include "common/dataset/dataset.h"

namespace epmap::sim {

struct BuildingWorld {
  Scene scene;  // grey
  // The walker's clothes and skin (see WalkerQuads); in the scene's textures, unused by it.
  Material walker_trousers, walker_shirt, walker_skin;
  // Footprints (floor frame) of the vertical faces of the walls, door frames included, and of
  // the furniture standing on the floor.
  std::vector<dataset::WallSegment> wall_faces;
  std::vector<dataset::WallSegment> furniture_faces;
};

inline constexpr double kBuildingWidthM = 28.0;  // x
inline constexpr double kBuildingDepthM = 28.5;  // y
inline constexpr double kCeilingHeightM = 2.6;

BuildingWorld BuildBuilding(uint64_t seed);

// The routes of the forward run (floor frame): the robot starts at the first point facing the
// second and drives straight between consecutive points, turning in place at each. Both start
// in room R1 facing north, so they share the world frame.
// - corridors (the default): about 59 m through a room, a door, both corridors and a second
//   room; the other six rooms are seen only through their doors.
// - rooms: about 60 m along corridor H, stepping 1.75 m into each room off it (seven of the
//   eight) to look around there, as a robot mapping the floor would.
// Throws std::invalid_argument for another name.
std::vector<Eigen::Vector2d> BuildingRoute(const std::string& name = "corridors");

// A person who walks to and fro along corridor H on their own (scenario building --walker):
// at 1.1 m/s along y = 15.0 (the corridor's north half; the route keeps to y = 14.25) between
// x = 4.5 and x = 12.5, pausing 1.5 s at each end; at t = 0 they set off west from x = 12.5.
// The robot drives this corridor about 25-55 s into the forward run and meets them there.
// WalkerPose: feet centre on the floor, x = walking direction, z up (floor frame), at time t.
inline constexpr double kWalkerHeightM = 1.75;
Eigen::Isometry3d WalkerPose(double t);
// The walker's body (legs, torso, head: three textured boxes) at `pose`, Quad::object = 1.
std::vector<Quad> WalkerQuads(const BuildingWorld& world, const Eigen::Isometry3d& pose);

}  // namespace epmap::sim
