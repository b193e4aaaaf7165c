#pragma once
// Paper 003, Sec. III-A-2: reference points clustered with a grid (the points falling into
// one grid cell form one reference object), each group represented by a 2-point line fitted by
// linear regression (Eq. 3-4), lines shorter than 5 cm removed.
//
// Coordinates are planar, in metres: the paper's (x, z) of the camera become the robot base
// frame's (x forward, y left) because our camera pans on the base; a view gathers the points of
// every pan position at one stop in the base frame.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace epmap::perceptual_map {

// A line surface: two end points in the frame of the view that saw it.
struct ReferenceObject {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  int point_count = 0;
  double rms_m = 0;  // RMS distance of its points to the line
  double length() const { return (b - a).norm(); }
  Eigen::Vector2d mid() const { return 0.5 * (a + b); }
};

// A reference object of the global map (world frame = the robot's start pose), with its id.
struct MapSegment {
  uint32_t id = 0;
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  uint32_t view_id = 0;       // the view that added it to the global map
  uint32_t observations = 1;  // views in which it was seen (added or tracked)
  double length() const { return (b - a).norm(); }
};

struct ClusteringParams {
  // Side of a grid cell. The paper fixes a size without giving it; 0.5 m keeps a cell within
  // one wall in rooms and corridors of a building.
  double cell_size_m = 0.5;
  int min_points = 6;          // fewer points in a cell make no reference object
  double min_length_m = 0.05;  // paper 003: reference objects shorter than 5 cm are removed
  double max_rms_m = 0.10;     // a cell whose points do not lie on a line (clutter) is dropped
  // ... plus this much per square metre of the cell's range from the view's origin: stereo
  // depth noise grows with the square of the range (z^2 sigma_d / (f b): 0.01 m/m^2 for the
  // building's 320x240 rig at 0.3 px), so a far wall's points scatter more about their line.
  // Four building runs: wall coverage +1.4 points (mean), stray length -0.4; any value from
  // 0.002 to 0.01 gave the same maps.
  double max_rms_growth_per_m2 = 0.005;
  // Far away, stereo depth noise stretches a wall's points along the line of sight; a cell then
  // fits a line pointing at the robot. Objects farther than radial_min_range_m whose line is
  // within radial_max_angle_rad of the line of sight from the view's origin and passes within
  // radial_min_offset_m of that origin are dropped (angle 0 disables). The offset keeps a
  // corridor's walls seen far ahead: they run along the line of sight too, but at the
  // corridor's half-width from the robot, where a stretched cell's line passes through it.
  // Four building runs: wall coverage 48.5 -> 53.2 % (mean), stray length 8.3 -> 8.2 %
  // (dropping the filter altogether: 52.5 %, stray 10.3 %).
  double radial_max_angle_rad = 0.35;  // 20 degrees
  double radial_min_range_m = 4.0;
  double radial_min_offset_m = 0.6;
  // Beyond far_from_range_m from the view's origin, points are grouped in cells of
  // far_cell_size_m instead (0 disables). A far wall's points scatter across the wall by the
  // depth noise (z^2 sigma_d / (f b): 0.4 m at 8 m on the building's rig at 0.3 px), as much
  // as a 0.5 m cell is wide: each cell then holds a sliver of the scatter whose fitted line
  // points anywhere. A larger cell holds the wall's whole scatter over a longer stretch, and
  // the regression (Eq. 3-4) averages it out along the wall. Four building runs: wall
  // coverage 54.6 -> 57.8 % (mean; better on each run), over the walls the cameras had in
  // view 77.3 -> 80.3 %, stray length 7.8 -> 9.1 % (perception/mobile_mapping/EXPERIMENTS.md).
  double far_from_range_m = 8.0;
  double far_cell_size_m = 1.0;
  void Validate() const;
};

// Groups the points (view frame) by grid cell and fits one line per cell (Eq. 3-4).
// T_grid_view places the grid: cells are squares of the grid frame. Passing the view's pose
// estimate in the world makes the grid world-aligned, so a wall is cut at the same places in
// successive views and tracked objects keep comparable end points (Sec. III-C).
// Objects are returned in the view frame, ordered by cell.
std::vector<ReferenceObject> FitReferenceObjects(const std::vector<Eigen::Vector2d>& points,
                                                 const Eigen::Isometry2d& T_grid_view,
                                                 const ClusteringParams& params);

// Eq. 3-4 on one group: regression of the coordinate of smaller spread on the other one (the
// paper regresses z on x; for a line nearly parallel to z that is ill-conditioned, so the two
// roles swap), end points at the minimum and maximum of the independent coordinate.
// Needs at least two distinct points; returns false otherwise.
bool FitLine(const std::vector<Eigen::Vector2d>& points, ReferenceObject* out);

}  // namespace epmap::perceptual_map
