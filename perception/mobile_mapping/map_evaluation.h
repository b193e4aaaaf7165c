#pragma once
// Figures that compare the maps with a ground truth (walls as 2-D segments) or with each other.
// Used by `epmap-bench maps`; pure functions so the figures themselves are tested.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "perception/occupancy/layered_grid.h"

namespace epmap::mobile_mapping {

struct Segment2 {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
};

// Share of the total length of `reference` that lies within tolerance_m of some segment of
// `candidates` (reference sampled every step_m). 0 when reference has no length.
double CoveredShare(const std::vector<Segment2>& reference, const std::vector<Segment2>& candidates,
                    double tolerance_m, double step_m = 0.05);

// Like CoveredShare, but only over the reference points that some viewpoint could see: within
// max_range_m and with no other reference segment in between (occluders = reference).
// Returns the share and, in visible_length_m, the length that was visible.
double CoveredVisibleShare(const std::vector<Segment2>& reference,
                           const std::vector<Segment2>& candidates, double tolerance_m,
                           const std::vector<Eigen::Vector2d>& viewpoints, double max_range_m,
                           double* visible_length_m = nullptr, double step_m = 0.05);

// The pieces of `reference` (one per step_m) that some viewpoint sees, as CoveredVisibleShare
// decides it: looking all around, so CoveredShare(reference, VisibleParts(...), tol) is an
// optimistic bound on what a map of the seen walls can cover (a wall's hidden face lies within
// tol of its seen one: 12 cm walls, 0.5 m). VisibleSeenParts below adds the field of view.
std::vector<Segment2> VisibleParts(const std::vector<Segment2>& reference,
                                   const std::vector<Eigen::Vector2d>& viewpoints,
                                   double max_range_m, double step_m = 0.05);

// A camera on the floor plan: where it stands, where its optical axis points (a unit vector)
// and half its horizontal field of view. An axis of zero length sees all around.
struct PlanarView {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  Eigen::Vector2d axis = Eigen::Vector2d::Zero();
  double half_fov_rad = 0;
};

// The pieces of `reference` (one per step_m) that some view has in its field of view, within
// max_range_m and with no other reference segment in between. Views closer than 0.25 m and
// 0.1 rad to the previous one kept are skipped (they see the same walls). With the cameras of
// the frames a map was built from, CoveredShare(reference, VisibleSeenParts(...), tol) is the
// most that map can cover.
std::vector<Segment2> VisibleSeenParts(const std::vector<Segment2>& reference,
                                       const std::vector<PlanarView>& views, double max_range_m,
                                       double step_m = 0.05);

double TotalLength(const std::vector<Segment2>& segments);

struct GridScore {
  double iou = 0;           // occupied cells vs true wall cells, over the whole grid extent
  double iou_observed = 0;  // the same, true wall cells counted only where the grid knows
  size_t occupied = 0;      // cells at or above the occupied threshold
  size_t wall_cells = 0;    // rasterised true walls inside the grid extent
  size_t wall_cells_observed = 0;
  size_t intersection = 0;
  double precision = 0;        // occupied cells that are wall cells (intersection / occupied)
  double recall_observed = 0;  // known wall cells found occupied (intersection / observed)
  // Where the occupied cells that are not wall cells lie: touching a wall cell (8-neighbour:
  // a wall drawn one cell off, or thicker than it is) or farther (furniture, scatter).
  size_t false_beside_wall = 0;
  size_t false_away_from_wall = 0;
};

// Rasterises the walls at the grid's resolution and lattice (every cell the wall line touches)
// and compares them with the cells
// whose occupancy is at or above occupied_threshold (0..100; map_server's 0.65 -> 65).
// The walls rasterised on the grid's lattice: 1 for every cell a wall line touches (a wall along
// a cell boundary marks the cells on both sides) and every cell whose centre lies inside a
// closed outline (consecutive segments that return to their start: a solid's body), row-major
// like the grid's bytes.
std::vector<uint8_t> RasteriseWalls(const occupancy::GridExport& grid,
                                    const std::vector<Segment2>& walls);

// A picture of ScoreGrid's comparison (y up, `scale` px per cell): green = occupied and wall,
// red = occupied but no wall, blue = wall seen but not occupied, light blue = wall never seen,
// white = free, grey = unknown. With `furniture` (footprints, as walls): occupied cells on a
// piece of furniture and no wall are yellow instead of red (solid, but not a wall).
cv::Mat GridErrorPicture(const occupancy::GridExport& grid, const std::vector<Segment2>& walls,
                         uint8_t occupied_threshold = 65, int scale = 4,
                         const std::vector<Segment2>& furniture = {});

GridScore ScoreGrid(const occupancy::GridExport& grid, const std::vector<Segment2>& walls,
                    uint8_t occupied_threshold = 65);

}  // namespace epmap::mobile_mapping
