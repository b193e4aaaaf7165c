#pragma once
// The furnished room the iCub-like head looks at (scenarios head and vergence), and the
// hand-sized toy that moves through it on its own. World frame = the head's base_link:
// x forward, y left, z up, origin at the neck's pivot, 1.05 m above the floor.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "clients/sim/renderer.h"
#include "clients/sim/scene_builder.h"

namespace epmap::sim {

struct HeadRoom {
  Scene scene;
  Material toy_material;
  Lighting lighting;
  uint64_t seed = 0;
};

// Builds the room: floor, ceiling, four walls (painted, some plain), posters, a bookshelf, a
// cabinet, a table with a laptop, books, a cereal box and small boxes on it. Deterministic in
// `seed`.
HeadRoom BuildHeadRoom(uint64_t seed);

// The moving toy: a 10 cm textured cube. It appears in cycles of kToyCycleS seconds: in each
// it enters from one side of the head's field of view, wanders at 0.5-0.95 m in front of the
// eyes above the table, and leaves on the other side. Returns its pose (cube centre) at time
// t, or nothing while it is away.
inline constexpr double kToyCycleS = 5.0;
inline constexpr double kToyEdgeM = 0.10;
std::optional<Eigen::Isometry3d> ToyPose(uint64_t seed, double t);

// The toy's faces at `pose`, with Quad::object = 1.
std::vector<Quad> ToyQuads(const HeadRoom& room, const Eigen::Isometry3d& pose);

}  // namespace epmap::sim
