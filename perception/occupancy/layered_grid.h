#pragma once
// Paper 002, Sec. 4: a layered fuzzy occupancy grid in the manner of FLOG (ref. [16]). Each
// layer is a band of heights above the floor; each cell (x, y, l) holds the membership mu_E to
// the empty set E_l, mu_O to the occupied set O_l and a confidence kappa (K_l). A 3-D point is
// added by updating the cells traversed by the ray from the stereo head to the point (empty
// before it, occupied where it is); a 3-D line feature is cut into parts and the midpoint of
// each part is added as a point. Local maps built at a panning stop are registered to the
// global map by correlating their synthetic maps M = U_l (O_l n K_l) over x and y, and merged
// by weighted averaging.
//
// The grid lives on a world-aligned lattice: cell (i, j) covers [i r, (i+1) r) x [j r, (j+1) r),
// so a local and a global grid of the same resolution share cells. It grows as points arrive.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace epmap::occupancy {

struct GridParams {
  double resolution_m = 0.1;
  // Layer l holds heights [bounds[l], bounds[l+1]) above the floor. Below the first bound is
  // the floor (seen free space, never an obstacle); above the last, the ceiling.
  std::vector<double> layer_bounds_m = {0.10, 0.70, 1.30, 2.00};
  double growth_margin_m = 4.0;  // extra room added each time the grid grows
  void Validate() const;
};

// How the evidence of many rays becomes a cell's memberships mu_O and mu_E.
enum class Membership {
  // Share of the (weighted) rays touching the cell that end in it: mu_O = H / (H + P + prior),
  // mu_E = P / (H + P + prior), H = weight of the points in the cell, P = weight of the rays
  // passing through it. A cell in front of a wall, where a few noisy points land but most rays
  // pass, stays free: on the building run, occupied cells on a wall face 955 -> 1109, beside
  // one 497 -> 339, far from walls and furniture 274 -> 107 (grid IoU over seen cells
  // 0.35 -> 0.51, perception/mobile_mapping/EXPERIMENTS.md).
  kRayFrequency,
  // FLOG's fuzzy union (probabilistic sum a + b - ab) of fixed evidence per ray: a handful of
  // noisy points saturates mu_O whatever the rays passing through say.
  kFuzzyUnion,
};

// How one measurement changes the memberships. The paper (and FLOG) leave the numbers open:
// these are our defaults.
struct MeasurementParams {
  Membership membership = Membership::kRayFrequency;
  double frequency_prior = 0.5;      // kRayFrequency: the "prior" weight in the denominators
  double empty_evidence = 0.25;      // kFuzzyUnion: on each cell the ray crosses before the point
  double occupied_evidence = 0.6;    // kFuzzyUnion: on the point's cell, times the range weight
  double confidence_evidence = 0.3;  // on every touched cell, times the range weight
  // The ray stops giving empty evidence this many range sigmas before the point (at least one
  // cell), so the point's own uncertainty never clears it. With kRayFrequency the passes a
  // noisy point's neighbours get are outweighed by the hits, so the gap can be smaller.
  double empty_gap_sigmas = 1.0;
  // ... and at least this share of a cell before it.
  double empty_gap_min_cells = 1.0;
  // A point also marks occupied the cells behind it along the ray up to this far (in the plane,
  // at its height): the body of the surface it lies on. 0 marks the point's cell only.
  double occupied_depth_m = 0.0;
  // Range weight w = min(1, (resolution / sigma)^weight_exponent).
  double weight_exponent = 1.0;
  // Farther points are ignored: at 8 m a stereo point of this rig is uncertain by more than
  // half a metre (z^2 sigma_d / f b), too vague for a 10 cm grid, and its ray would clear
  // walls it passes by.
  double max_range_m = 5.0;
  void Validate() const;
};

// Memberships of one cell.
struct Cell {
  float empty = 0;
  float occupied = 0;
  float confidence = 0;
};

// A grid exported for planners: bytes as the gRPC OccupancyGrid and ROS OccupancyGrid expect.
struct GridExport {
  double resolution_m = 0;
  double origin_x = 0, origin_y = 0;  // world position of cell (0, 0)'s lower-left corner
  uint32_t width = 0, height = 0;     // cells along x and y
  uint32_t layer_count = 0;
  std::vector<double> layer_bounds_m;
  bool combined = true;
  uint32_t layer = 0;
  // combined: the number of bands it combines, from the floor up (layer_count for all of them;
  // fewer for the obstacles a robot of some height can hit, ExportBelow).
  uint32_t combined_layers = 0;
  // Row-major from the lowest y row. occupancy 0..100 = 50 + 50 (mu_O - mu_E), 255 = unknown
  // (confidence below the export threshold); confidence 0..255 = 255 kappa.
  std::vector<uint8_t> occupancy;
  std::vector<uint8_t> confidence;
  static constexpr uint8_t kUnknown = 255;
};

// A window of the grid's lattice (lattice cell (ix, iy) spans [ix, ix + 1) x [iy, iy + 1) times
// the resolution, anchored at the world origin): cells ix0 .. ix0 + width - 1 along x and
// iy0 .. iy0 + height - 1 along y. What a local planner asks for: the map around the robot.
struct CellWindow {
  int64_t ix0 = 0, iy0 = 0;
  uint32_t width = 0, height = 0;
  size_t cells() const { return static_cast<size_t>(width) * height; }
};

// The window of every cell that the world box [min_x, max_x] x [min_y, max_y] (m) overlaps on
// a lattice of resolution_m. Throws std::invalid_argument for a box that is not finite, not
// min < max on both axes, or wider than max_cells_per_side cells along an axis.
CellWindow WindowOverBox(double resolution_m, double min_x, double min_y, double max_x,
                         double max_y, int64_t max_cells_per_side = 1 << 20);

class LayeredGrid {
 public:
  explicit LayeredGrid(const GridParams& params = {});
  // Copies share the cells until one of them changes: the one that changes copies them first
  // (copy on write), so a snapshot handed to readers never changes under them, and a snapshot
  // taken while the map does not change (the base driving between stops) costs no copy.
  // As for any value, one grid object is not copied or read while another thread changes it;
  // copies of it may be read, copied and dropped on any thread meanwhile. A moved-from grid
  // may only be assigned or destroyed.
  LayeredGrid(const LayeredGrid& other) = default;
  LayeredGrid& operator=(const LayeredGrid& other) = default;
  LayeredGrid(LayeredGrid&&) noexcept = default;
  LayeredGrid& operator=(LayeredGrid&&) noexcept = default;
  // A copy with cells of its own from the start (what every copy cost before copy on write:
  // epmap-bench maps times it as the snapshot's baseline).
  LayeredGrid DeepCopy() const;

  // Adds one 3-D point seen from origin (both in the world frame, z = height above the floor).
  // range_sigma_m is the point's depth uncertainty (from the disparity noise). Returns false
  // (and changes nothing) for a non-finite point, a point beyond max_range_m or at the origin.
  bool AddPoint(const Eigen::Vector3d& origin, const Eigen::Vector3d& point, double range_sigma_m,
                const MeasurementParams& params);

  // Adds a 3-D line feature [a, b] as `parts` point measurements at the midpoints of equal
  // parts (paper 002: parts of a predetermined image-plane length; the caller turns that length
  // into the count, see PartsForImageLength). Returns the number of points added.
  int AddSegment(const Eigen::Vector3d& origin, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                 int parts, double range_sigma_m, const MeasurementParams& params);

  int layer_count() const { return static_cast<int>(params_.layer_bounds_m.size()) - 1; }
  const GridParams& params() const { return params_; }
  double resolution() const { return params_.resolution_m; }
  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return width_ == 0; }
  // World position of cell (0, 0)'s lower-left corner.
  Eigen::Vector2d origin() const;
  // Lattice index of cell (0, 0): cell (c, r) is lattice cell (min_ix + c, min_iy + r).
  int64_t min_ix() const { return min_ix_; }
  int64_t min_iy() const { return min_iy_; }

  // Layer index of a height above the floor, or -1 (floor or ceiling).
  int LayerOf(double height_m) const;

  // A cell of one layer; throws std::out_of_range naming the layer if it does not exist.
  // Cells outside the grid read as all zero (never seen).
  Cell At(int layer, int64_t ix, int64_t iy) const;
  // The combined map over the layers: occupied if any layer is, empty where some layer was
  // seen empty and none is occupied: O = max_l O_l, E = min(max_l E_l, 1 - O), K = max_l K_l.
  Cell Combined(int64_t ix, int64_t iy) const { return Combined(ix, iy, layer_count()); }
  // The same over the lowest `first_layers` layers only (0 < first_layers <= layer_count()).
  Cell Combined(int64_t ix, int64_t iy, int first_layers) const;
  // How many bands start below height_m above the floor: the ones in which a robot that tall
  // can hit something (0 when height_m is not above the lowest band's floor, or not finite).
  int LayersBelow(double height_m) const;
  // Lattice cell of a world point.
  int64_t CellX(double x) const;
  int64_t CellY(double y) const;

  // The synthetic map used for correlation, M = U_l (O_l n K_l) with n = min, U = max
  // (paper 002, Sec. 4), CV_32FC1 of height() x width(), row r = lattice row min_iy() + r.
  cv::Mat SyntheticMap() const;

  // Export of one layer, or the combined map when layer is empty, cropped to the known cells
  // (plus one cell). Throws std::out_of_range for a layer that does not exist. Cells with
  // confidence below unknown_below are unknown.
  GridExport Export(std::optional<int> layer = std::nullopt, double unknown_below = 0.05) const;
  // Export of the combined map over the lowest `first_layers` layers (see Combined); throws
  // std::out_of_range unless 0 < first_layers <= layer_count().
  GridExport ExportBelow(int first_layers, double unknown_below = 0.05) const;
  // The same two, of exactly `window` (not cropped: cells outside the grid are unknown). Costs
  // the window's cells, not the grid's.
  GridExport ExportWindow(const CellWindow& window, std::optional<int> layer = std::nullopt,
                          double unknown_below = 0.05) const;
  GridExport ExportBelowWindow(const CellWindow& window, int first_layers,
                               double unknown_below = 0.05) const;

  // Weighted averaging of a registered local map into this one (paper 002, Sec. 4, as [16]):
  // each cell's memberships become the confidence-weighted mean of the two, its confidence the
  // fuzzy union of both. The local map is shifted by (shift_x, shift_y) cells first.
  void MergeWeighted(const LayeredGrid& local, int shift_x_cells = 0, int shift_y_cells = 0);

  // The cells of one layer, as a saved map holds them.
  struct LayerPlanes {
    cv::Mat empty, occupied, confidence;  // CV_32FC1, height() x width()
    // kRayFrequency: weight of the points in each cell (hits) and of the rays through it
    // (passes). A merged (global) map has none (empty Mats): its memberships are averages.
    cv::Mat hits, passes;
  };
  // Every layer's cells, read-only (for saving a map: mobile_mapping's state).
  const std::vector<LayerPlanes>& planes() const { return *layers_; }
  // Replaces the cells with saved ones: lattice cell (min_ix + c, min_iy + r) is (c, r) of each
  // plane. Throws std::invalid_argument, leaving the grid as it was, when they do not fit this
  // grid: another layer count, planes not CV_32FC1 of height x width, memberships and
  // confidence not within [0, 1], weights negative or not finite.
  void RestorePlanes(int64_t min_ix, int64_t min_iy, int width, int height,
                     std::vector<LayerPlanes> planes);

 private:
  using Layer = LayerPlanes;
  void EnsureCovers(int64_t ix_lo, int64_t iy_lo, int64_t ix_hi, int64_t iy_hi);
  void CheckLayer(int layer) const;
  void CheckFirstLayers(int first_layers) const;
  Cell CombineLowest(int64_t ix, int64_t iy, int first_layers) const;  // Combined, unchecked
  // Cells c0 .. c1 - 1 of grid row r (0 .. height() - 1) into out: of `layer`, or without one
  // the combined map of the lowest first_layers (as CombineLowest), read row by row from the
  // planes (an export reads every cell; At() per cell cost it several times more).
  void ReadRow(std::optional<int> layer, int first_layers, int r, int c0, int c1, Cell* out) const;
  // The export of ReadRow's cells, cropped to the known ones plus one (ExportCellsIn of that box).
  GridExport ExportCells(std::optional<int> layer, int first_layers, double unknown_below) const;
  // The same over exactly `window`.
  GridExport ExportCellsIn(const CellWindow& window, std::optional<int> layer, int first_layers,
                           double unknown_below) const;

  // The layers to change: this grid's own, copied first if a copy of the grid shares them.
  std::vector<Layer>& MutableLayers();

  GridParams params_;
  std::shared_ptr<std::vector<Layer>> layers_;  // shared by copies until one changes
  int64_t min_ix_ = 0, min_iy_ = 0;
  int width_ = 0, height_ = 0;
};

// Number of parts for a line feature whose image-plane length is image_length_px, cut into
// parts of part_length_px (at least one).
int PartsForImageLength(double image_length_px, double part_length_px);

// Result of correlating a local map against the global one over x and y shifts.
struct Registration {
  int dx_cells = 0, dy_cells = 0;  // best integer shift of the local map
  double dx_m = 0, dy_m = 0;       // the same, refined to sub-cell by a parabola through the peak
  double score = 0;                // correlation at the best shift
  double zero_score = 0;           // correlation with no shift
  // How sharp the peak is along each axis, (2 C(0) - C(-1) - C(+1)) / C(0) around the best
  // shift: near 0 along a corridor (nothing fixes the position along it), up to 2 for a spike.
  double sharpness_x = 0, sharpness_y = 0;
  size_t local_cells = 0;  // cells of the local synthetic map with a non-zero value
};

// Correlation C(dx, dy) = sum_c M_local(c) M_global(c + (dx, dy)) over shifts within
// search_radius_m (paper 002, Sec. 4: the translation search; heading comes from vision).
// Both grids must have the same resolution. Throws std::invalid_argument otherwise.
Registration CorrelateMaps(const LayeredGrid& local, const LayeredGrid& global,
                           double search_radius_m);

}  // namespace epmap::occupancy
