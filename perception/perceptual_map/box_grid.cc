#include "perception/perceptual_map/box_grid.h"

#include <algorithm>
#include <cmath>

namespace epmap::perceptual_map {

BoxGrid::BoxGrid(double cell_m) : cell_m_(cell_m > 0 && std::isfinite(cell_m) ? cell_m : 0) {}

int64_t BoxGrid::CellOf(double v) const {
  // Coordinates are metres in a building-sized frame; the clamp only keeps the cast defined.
  return static_cast<int64_t>(std::floor(std::clamp(v / cell_m_, -1e12, 1e12)));
}

uint64_t BoxGrid::Key(int64_t ix, int64_t iy) {
  return (static_cast<uint64_t>(ix) << 32) ^ (static_cast<uint64_t>(iy) & 0xffffffffULL);
}

void BoxGrid::Add(uint32_t item, const Eigen::AlignedBox2d& box) {
  if (item >= seen_in_query_.size()) seen_in_query_.resize(static_cast<size_t>(item) + 1, 0);
  if (cell_m_ == 0 || !box.min().allFinite() || !box.max().allFinite()) {
    everywhere_.push_back(item);
    return;
  }
  const int64_t x0 = CellOf(box.min().x()), x1 = CellOf(box.max().x());
  const int64_t y0 = CellOf(box.min().y()), y1 = CellOf(box.max().y());
  if (x1 - x0 >= kMaxCellsPerItem || y1 - y0 >= kMaxCellsPerItem ||
      (x1 - x0 + 1) * (y1 - y0 + 1) > kMaxCellsPerItem) {
    // A box over very many cells (a wild segment, e.g. from a damaged saved map) is listed once
    // for every query instead of once per cell: the same answers, and memory stays bounded.
    everywhere_.push_back(item);
    return;
  }
  if (max_ix_ < min_ix_) {
    min_ix_ = x0, max_ix_ = x1, min_iy_ = y0, max_iy_ = y1;
  } else {
    min_ix_ = std::min(min_ix_, x0), max_ix_ = std::max(max_ix_, x1);
    min_iy_ = std::min(min_iy_, y0), max_iy_ = std::max(max_iy_, y1);
  }
  for (int64_t ix = x0; ix <= x1; ++ix) {
    for (int64_t iy = y0; iy <= y1; ++iy) cells_[Key(ix, iy)].push_back(item);
  }
}

void BoxGrid::Query(const Eigen::AlignedBox2d& box, std::vector<uint32_t>* out) const {
  out->clear();
  const uint64_t query = ++queries_;
  const auto take = [&](const std::vector<uint32_t>& items) {
    for (const uint32_t item : items) {
      if (seen_in_query_[item] == query) continue;
      seen_in_query_[item] = query;
      out->push_back(item);
    }
  };
  take(everywhere_);
  if (!box.min().allFinite() || !box.max().allFinite()) {
    for (const auto& [key, items] : cells_) take(items);
  } else if (!cells_.empty()) {
    // Only the part of the box over cells that hold items: a wide box costs no more than the
    // index's extent.
    const int64_t x0 = std::max(min_ix_, CellOf(box.min().x()));
    const int64_t x1 = std::min(max_ix_, CellOf(box.max().x()));
    const int64_t y0 = std::max(min_iy_, CellOf(box.min().y()));
    const int64_t y1 = std::min(max_iy_, CellOf(box.max().y()));
    for (int64_t ix = x0; ix <= x1; ++ix) {
      for (int64_t iy = y0; iy <= y1; ++iy) {
        const auto it = cells_.find(Key(ix, iy));
        if (it != cells_.end()) take(it->second);
      }
    }
  }
}

bool BoxGrid::Covers(const Eigen::AlignedBox2d& box) const {
  if (cells_.empty()) return true;
  if (!box.min().allFinite() || !box.max().allFinite()) return false;
  return CellOf(box.min().x()) <= min_ix_ && CellOf(box.max().x()) >= max_ix_ &&
         CellOf(box.min().y()) <= min_iy_ && CellOf(box.max().y()) >= max_iy_;
}

}  // namespace epmap::perceptual_map
