#pragma once
// A uniform grid over the bounding boxes of numbered items (segments, path lines): which items
// may lie near a point or a box. Paper 003's redundancy removal (III-D) compares every path
// point with every object; looking only at nearby cells gives the same answers at a cost that
// grows with the map rather than with the map times the path.

#include <Eigen/Geometry>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace epmap::perceptual_map {

class BoxGrid {
 public:
  // cell_m <= 0: one cell holds everything (every query returns every item).
  explicit BoxGrid(double cell_m);

  // Items are numbered from 0 (ids index a table of the size of the largest). A box that is
  // not finite, or spans more than kMaxCellsPerItem cells, is returned by every query.
  static constexpr int64_t kMaxCellsPerItem = 4096;
  void Add(uint32_t item, const Eigen::AlignedBox2d& box);

  // The items whose box may intersect `box` (a superset of those that do: all items of the
  // cells it touches), each once, in no particular order. Replaces *out. Not for concurrent
  // calls on one grid (it marks the items it has seen).
  void Query(const Eigen::AlignedBox2d& box, std::vector<uint32_t>* out) const;
  // True when `box` covers every cell that holds an item (a query returns every item).
  bool Covers(const Eigen::AlignedBox2d& box) const;

 private:
  int64_t CellOf(double v) const;
  static uint64_t Key(int64_t ix, int64_t iy);

  double cell_m_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells_;
  std::vector<uint32_t> everywhere_;  // cell_m <= 0, or boxes that are not finite
  // Per item, the query that last returned it: an item spanning several cells is listed in
  // each, and sorting the candidates to drop repeats cost more than the distances themselves.
  mutable std::vector<uint64_t> seen_in_query_;
  mutable uint64_t queries_ = 0;
  int64_t min_ix_ = 0, min_iy_ = 0, max_ix_ = -1, max_iy_ = -1;  // extent of cells_
};

}  // namespace epmap::perceptual_map
