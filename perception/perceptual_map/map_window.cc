#include "perception/perceptual_map/map_window.h"

#include <algorithm>

namespace epmap::perceptual_map {

bool SegmentTouchesBox(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                       const Eigen::AlignedBox2d& box) {
  if (box.isEmpty() || !a.allFinite() || !b.allFinite()) return false;
  // Clip the parameter range t in [0, 1] of a + t (b - a) by each slab of the box
  // (Liang-Barsky); the segment touches the box when some t survives all four.
  const Eigen::Vector2d d = b - a;
  double t0 = 0.0, t1 = 1.0;
  for (int axis = 0; axis < 2; ++axis) {
    const double lo = box.min()[axis], hi = box.max()[axis];
    if (d[axis] == 0.0) {
      if (a[axis] < lo || a[axis] > hi) return false;  // parallel to the slab, outside it
      continue;
    }
    double enter = (lo - a[axis]) / d[axis], leave = (hi - a[axis]) / d[axis];
    if (enter > leave) std::swap(enter, leave);
    t0 = std::max(t0, enter);
    t1 = std::min(t1, leave);
    if (t0 > t1) return false;
  }
  return true;
}

std::vector<MapSegment> SegmentsInBox(const std::vector<MapSegment>& segments,
                                      const Eigen::AlignedBox2d& box) {
  std::vector<MapSegment> in;
  for (const auto& s : segments) {
    if (SegmentTouchesBox(s.a, s.b, box)) in.push_back(s);
  }
  return in;
}

}  // namespace epmap::perceptual_map
