#pragma once
// Paper 003, Sec. III-D: redundancy removal and the boundary of the global map. Reference
// objects crossing the path are removed (the robot drove through them, so they are not
// surfaces); the rest are split into inner and outer objects (the two sides of the path); for
// each point of the path the nearest few objects on each side are kept, the others are
// redundant; the kept objects of each side, ordered along the path, are joined into a boundary.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "perception/perceptual_map/reference_objects.h"

namespace epmap::perceptual_map {

struct BoundaryParams {
  // The paper keeps "an appropriate number" of objects per path point: two per side by default.
  int objects_per_side = 2;
  double max_distance_m = 6.0;  // objects farther than this from the path point are not kept
  double path_sample_m = 0.5;   // path lines are sampled at this spacing ("path line points")
  // Cell of the grids that find the objects and path lines near a point (box_grid.h). Any
  // size gives the same boundary; 0 compares everything with everything (the paper's direct
  // reading: quadratic in the run's length, 150 ms on a 1 km path against 0.8 ms on 60 m).
  double index_cell_m = 2.0;
  void Validate() const;
};

struct Boundary {
  std::vector<uint32_t> removed_on_path;  // ids of objects that cross the path
  std::vector<uint32_t> inner_ids;        // kept objects on the inner side, ordered along the path
  std::vector<uint32_t> outer_ids;        // kept objects on the outer side, ordered along the path
  std::vector<Eigen::Vector2d> inner;     // inner boundary polyline
  std::vector<Eigen::Vector2d> outer;     // outer boundary polyline
  bool inner_is_left = true;              // inner = the side the path turns towards overall
};

// The path is the robot's positions in the map frame, in time order (repeated points allowed).
// With fewer than two distinct path points there are no sides: every object counts as outer.
Boundary ComputeBoundary(const std::vector<MapSegment>& segments,
                         const std::vector<Eigen::Vector2d>& path, const BoundaryParams& params);

// True if segments [a1, a2] and [b1, b2] intersect (touching counts).
bool SegmentsIntersect(const Eigen::Vector2d& a1, const Eigen::Vector2d& a2,
                       const Eigen::Vector2d& b1, const Eigen::Vector2d& b2);

// Distance from q to the segment [a, b].
double PointSegmentDistance(const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                            const Eigen::Vector2d& b);

}  // namespace epmap::perceptual_map
