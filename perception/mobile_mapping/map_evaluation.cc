#include "perception/mobile_mapping/map_evaluation.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "perception/perceptual_map/boundary.h"

namespace epmap::mobile_mapping {

namespace {

using perceptual_map::PointSegmentDistance;
using perceptual_map::SegmentsIntersect;

// Sample points (with the length each stands for) along a set of segments.
struct Sample {
  Eigen::Vector2d p;
  double weight;
  size_t segment;
};

std::vector<Sample> SampleSegments(const std::vector<Segment2>& segments, double step) {
  std::vector<Sample> out;
  for (size_t i = 0; i < segments.size(); ++i) {
    const Eigen::Vector2d d = segments[i].b - segments[i].a;
    const double len = d.norm();
    if (!(len > 0) || !std::isfinite(len)) continue;
    const int n = std::max(1, static_cast<int>(std::ceil(len / step)));
    for (int k = 0; k < n; ++k) {
      out.push_back({segments[i].a + d * ((k + 0.5) / n), len / n, i});
    }
  }
  return out;
}

bool Near(const Eigen::Vector2d& q, const std::vector<Segment2>& segments, double tol) {
  for (const auto& s : segments) {
    if (PointSegmentDistance(q, s.a, s.b) <= tol) return true;
  }
  return false;
}

}  // namespace

double TotalLength(const std::vector<Segment2>& segments) {
  double sum = 0;
  for (const auto& s : segments) sum += (s.b - s.a).norm();
  return sum;
}

double CoveredShare(const std::vector<Segment2>& reference, const std::vector<Segment2>& candidates,
                    double tol, double step) {
  double total = 0, covered = 0;
  for (const auto& s : SampleSegments(reference, step)) {
    total += s.weight;
    if (Near(s.p, candidates, tol)) covered += s.weight;
  }
  return total > 0 ? covered / total : 0.0;
}

double CoveredVisibleShare(const std::vector<Segment2>& reference,
                           const std::vector<Segment2>& candidates, double tol,
                           const std::vector<Eigen::Vector2d>& viewpoints, double max_range,
                           double* visible_length, double step) {
  // Viewpoints thinned to one per half metre: neighbours see the same walls.
  std::vector<Eigen::Vector2d> views;
  for (const auto& v : viewpoints) {
    if (views.empty() || (v - views.back()).norm() >= 0.5) views.push_back(v);
  }
  double total = 0, covered = 0;
  for (const auto& s : SampleSegments(reference, step)) {
    bool visible = false;
    for (const auto& v : views) {
      if ((s.p - v).norm() > max_range) continue;
      // Stop just short of the wall so the wall itself does not occlude its own point.
      const Eigen::Vector2d q = s.p + (v - s.p).normalized() * 0.02;
      bool blocked = false;
      for (size_t w = 0; w < reference.size() && !blocked; ++w) {
        if (w == s.segment) continue;
        blocked = SegmentsIntersect(v, q, reference[w].a, reference[w].b);
      }
      if (!blocked) {
        visible = true;
        break;
      }
    }
    if (!visible) continue;
    total += s.weight;
    if (Near(s.p, candidates, tol)) covered += s.weight;
  }
  if (visible_length) *visible_length = total;
  return total > 0 ? covered / total : 0.0;
}

GridScore ScoreGrid(const occupancy::GridExport& g, const std::vector<Segment2>& walls,
                    uint8_t occupied_threshold) {
  GridScore score;
  const size_t n = static_cast<size_t>(g.width) * g.height;
  if (n == 0 || g.occupancy.size() != n) return score;
  std::vector<uint8_t> wall(n, 0);
  const double res = g.resolution_m;
  for (const auto& w : walls) {
    const Eigen::Vector2d d = w.b - w.a;
    const int steps = std::max(1, static_cast<int>(std::ceil(d.norm() / (0.25 * res))));
    for (int k = 0; k <= steps; ++k) {
      const Eigen::Vector2d p = w.a + d * (static_cast<double>(k) / steps);
      const long c = static_cast<long>(std::floor((p.x() - g.origin_x) / res));
      const long r = static_cast<long>(std::floor((p.y() - g.origin_y) / res));
      if (c < 0 || r < 0 || c >= static_cast<long>(g.width) || r >= static_cast<long>(g.height)) {
        continue;
      }
      wall[static_cast<size_t>(r) * g.width + static_cast<size_t>(c)] = 1;
    }
  }
  size_t uni = 0, uni_obs = 0;
  for (size_t i = 0; i < n; ++i) {
    const bool known = g.occupancy[i] != occupancy::GridExport::kUnknown;
    const bool occ = known && g.occupancy[i] >= occupied_threshold;
    score.occupied += occ;
    score.wall_cells += wall[i];
    score.wall_cells_observed += wall[i] && known;
    score.intersection += occ && wall[i];
    uni += occ || wall[i];
    uni_obs += occ || (wall[i] && known);
  }
  score.iou = uni ? static_cast<double>(score.intersection) / static_cast<double>(uni) : 0.0;
  score.iou_observed =
      uni_obs ? static_cast<double>(score.intersection) / static_cast<double>(uni_obs) : 0.0;
  return score;
}

}  // namespace epmap::mobile_mapping
