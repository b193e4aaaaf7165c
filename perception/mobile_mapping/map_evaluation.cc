#include "perception/mobile_mapping/map_evaluation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

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
    // The tolerance keeps a piece exactly one step long (VisibleParts) at one sample.
    const int n = std::max(1, static_cast<int>(std::ceil(len / step - 1e-9)));
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

// True if segment [a, b] touches the closed box [lo, hi] (Liang-Barsky clipping).
bool SegmentTouchesBox(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                       const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  const double eps = 1e-9;
  double t0 = 0, t1 = 1;
  const Eigen::Vector2d d = b - a;
  for (int k = 0; k < 2; ++k) {
    if (std::abs(d[k]) < 1e-15) {
      if (a[k] < lo[k] - eps || a[k] > hi[k] + eps) return false;
      continue;
    }
    double ta = (lo[k] - eps - a[k]) / d[k], tb = (hi[k] + eps - a[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
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

namespace {

// The sample pieces some view sees (field of view when the view has an axis, range, no other
// reference segment in between).
std::vector<Segment2> PartsSeenFrom(const std::vector<Segment2>& reference,
                                    const std::vector<PlanarView>& views, double max_range,
                                    double step) {
  std::vector<Segment2> parts;
  for (const auto& s : SampleSegments(reference, step)) {
    bool visible = false;
    for (const auto& view : views) {
      const Eigen::Vector2d& v = view.position;
      const Eigen::Vector2d ray = s.p - v;
      const double range = ray.norm();
      if (range > max_range) continue;
      if (view.axis.squaredNorm() > 0 &&
          ray.dot(view.axis) < range * view.axis.norm() * std::cos(view.half_fov_rad)) {
        continue;
      }
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
    const Segment2& seg = reference[s.segment];
    const Eigen::Vector2d half = (seg.b - seg.a).normalized() * (0.5 * s.weight);
    parts.push_back({s.p - half, s.p + half});
  }
  return parts;
}

}  // namespace

std::vector<Segment2> VisibleParts(const std::vector<Segment2>& reference,
                                   const std::vector<Eigen::Vector2d>& viewpoints, double max_range,
                                   double step) {
  // Viewpoints thinned to one per half metre: neighbours see the same walls.
  std::vector<PlanarView> views;
  for (const auto& v : viewpoints) {
    if (views.empty() || (v - views.back().position).norm() >= 0.5)
      views.push_back({v, Eigen::Vector2d::Zero(), 0});
  }
  return PartsSeenFrom(reference, views, max_range, step);
}

std::vector<Segment2> VisibleSeenParts(const std::vector<Segment2>& reference,
                                       const std::vector<PlanarView>& views, double max_range,
                                       double step) {
  std::vector<PlanarView> kept;
  for (const auto& v : views) {
    if (!v.position.allFinite() || !v.axis.allFinite()) continue;
    // Unit axes 0.1 apart are 0.1 rad apart; an all-around view differs from any other.
    if (!kept.empty() && (v.position - kept.back().position).norm() < 0.25 &&
        (v.axis - kept.back().axis).norm() < 0.1 && v.half_fov_rad <= kept.back().half_fov_rad) {
      continue;
    }
    kept.push_back(v);
  }
  return PartsSeenFrom(reference, kept, max_range, step);
}

double CoveredVisibleShare(const std::vector<Segment2>& reference,
                           const std::vector<Segment2>& candidates, double tol,
                           const std::vector<Eigen::Vector2d>& viewpoints, double max_range,
                           double* visible_length, double step) {
  const auto parts = VisibleParts(reference, viewpoints, max_range, step);
  if (visible_length) *visible_length = TotalLength(parts);
  // Each part is one step long: sampled once, at the sample point it was made from.
  return CoveredShare(parts, candidates, tol, step);
}

std::vector<uint8_t> RasteriseWalls(const occupancy::GridExport& g,
                                    const std::vector<Segment2>& walls) {
  const size_t n = static_cast<size_t>(g.width) * g.height;
  // Supercover rasterisation: every cell whose closed square the wall touches (a wall along
  // a cell boundary marks the cells on both sides, as either could hold its surface).
  std::vector<uint8_t> wall(n, 0);
  const double res = g.resolution_m;
  const auto cell_range = [&](double lo, double hi, double origin, uint32_t size) {
    return std::pair(std::max(0L, static_cast<long>(std::floor((lo - origin) / res)) - 1),
                     std::min(static_cast<long>(size) - 1,
                              static_cast<long>(std::floor((hi - origin) / res)) + 1));
  };
  for (const auto& w : walls) {
    const auto [c0, c1] =
        cell_range(std::min(w.a.x(), w.b.x()), std::max(w.a.x(), w.b.x()), g.origin_x, g.width);
    const auto [r0, r1] =
        cell_range(std::min(w.a.y(), w.b.y()), std::max(w.a.y(), w.b.y()), g.origin_y, g.height);
    for (long r = r0; r <= r1; ++r) {
      for (long c = c0; c <= c1; ++c) {
        const Eigen::Vector2d lo(g.origin_x + c * res, g.origin_y + r * res);
        const Eigen::Vector2d hi = lo + Eigen::Vector2d(res, res);
        if (SegmentTouchesBox(w.a, w.b, lo, hi)) {
          wall[static_cast<size_t>(r) * g.width + static_cast<size_t>(c)] = 1;
        }
      }
    }
  }
  // The body inside each closed outline (walls.csv and furniture.csv list each solid as
  // consecutive segments that return to where they began): a cell lying wholly inside a 12 cm
  // wall touches neither face but is wall all the same. Cells whose centre is inside
  // (crossing-number test over the loop's edges).
  for (size_t first = 0; first < walls.size();) {
    size_t last = first;
    while (last + 1 < walls.size() && (walls[last].b - walls[last + 1].a).norm() < 1e-6) ++last;
    const bool closed = last > first + 1 && (walls[last].b - walls[first].a).norm() < 1e-6;
    if (closed) {
      double x_lo = walls[first].a.x(), x_hi = x_lo, y_lo = walls[first].a.y(), y_hi = y_lo;
      for (size_t k = first; k <= last; ++k) {
        x_lo = std::min(x_lo, walls[k].b.x());
        x_hi = std::max(x_hi, walls[k].b.x());
        y_lo = std::min(y_lo, walls[k].b.y());
        y_hi = std::max(y_hi, walls[k].b.y());
      }
      const auto [c0, c1] = cell_range(x_lo, x_hi, g.origin_x, g.width);
      const auto [r0, r1] = cell_range(y_lo, y_hi, g.origin_y, g.height);
      for (long r = r0; r <= r1; ++r) {
        const double y = g.origin_y + (r + 0.5) * res;
        for (long c = c0; c <= c1; ++c) {
          const double x = g.origin_x + (c + 0.5) * res;
          bool inside = false;
          for (size_t k = first; k <= last; ++k) {
            const Eigen::Vector2d& a = walls[k].a;
            const Eigen::Vector2d& b = walls[k].b;
            if ((a.y() > y) != (b.y() > y) &&
                x < a.x() + (y - a.y()) * (b.x() - a.x()) / (b.y() - a.y())) {
              inside = !inside;
            }
          }
          if (inside) wall[static_cast<size_t>(r) * g.width + static_cast<size_t>(c)] = 1;
        }
      }
    }
    first = last + 1;
  }
  return wall;
}

GridScore ScoreGrid(const occupancy::GridExport& g, const std::vector<Segment2>& walls,
                    uint8_t occupied_threshold) {
  GridScore score;
  const size_t n = static_cast<size_t>(g.width) * g.height;
  if (n == 0 || g.occupancy.size() != n) return score;
  const std::vector<uint8_t> wall = RasteriseWalls(g, walls);
  size_t uni = 0, uni_obs = 0;
  for (uint32_t r = 0; r < g.height; ++r) {
    for (uint32_t c = 0; c < g.width; ++c) {
      const size_t i = static_cast<size_t>(r) * g.width + c;
      const bool known = g.occupancy[i] != occupancy::GridExport::kUnknown;
      const bool occ = known && g.occupancy[i] >= occupied_threshold;
      score.occupied += occ;
      score.wall_cells += wall[i];
      score.wall_cells_observed += wall[i] && known;
      score.intersection += occ && wall[i];
      uni += occ || wall[i];
      uni_obs += occ || (wall[i] && known);
      if (!occ || wall[i]) continue;
      // A false positive: does it touch a wall cell?
      bool beside = false;
      for (uint32_t rr = r > 0 ? r - 1 : 0; rr <= std::min(r + 1, g.height - 1) && !beside; ++rr) {
        for (uint32_t cc = c > 0 ? c - 1 : 0; cc <= std::min(c + 1, g.width - 1); ++cc) {
          if (wall[static_cast<size_t>(rr) * g.width + cc]) {
            beside = true;
            break;
          }
        }
      }
      ++(beside ? score.false_beside_wall : score.false_away_from_wall);
    }
  }
  score.iou = uni ? static_cast<double>(score.intersection) / static_cast<double>(uni) : 0.0;
  score.iou_observed =
      uni_obs ? static_cast<double>(score.intersection) / static_cast<double>(uni_obs) : 0.0;
  const auto share = [&](size_t of) {
    return of ? static_cast<double>(score.intersection) / static_cast<double>(of) : 0.0;
  };
  score.precision = share(score.occupied);
  score.recall_observed = share(score.wall_cells_observed);
  return score;
}

}  // namespace epmap::mobile_mapping

namespace epmap::mobile_mapping {

cv::Mat GridErrorPicture(const occupancy::GridExport& g, const std::vector<Segment2>& walls,
                         uint8_t occupied_threshold, int scale,
                         const std::vector<Segment2>& furniture) {
  const size_t n = static_cast<size_t>(g.width) * g.height;
  cv::Mat img(static_cast<int>(g.height), static_cast<int>(g.width), CV_8UC3);
  if (n == 0 || g.occupancy.size() != n) return img;
  const std::vector<uint8_t> wall = RasteriseWalls(g, walls);
  const std::vector<uint8_t> solid =
      furniture.empty() ? std::vector<uint8_t>(n, 0) : RasteriseWalls(g, furniture);
  for (uint32_t r = 0; r < g.height; ++r) {
    auto* row = img.ptr<cv::Vec3b>(static_cast<int>(g.height - 1 - r));
    for (uint32_t c = 0; c < g.width; ++c) {
      const size_t i = static_cast<size_t>(r) * g.width + c;
      const bool known = g.occupancy[i] != occupancy::GridExport::kUnknown;
      const bool occ = known && g.occupancy[i] >= occupied_threshold;
      cv::Vec3b colour = known ? cv::Vec3b(255, 255, 255) : cv::Vec3b(160, 160, 160);
      if (occ && wall[i]) colour = cv::Vec3b(0, 170, 0);  // true positive: green
      if (occ && !wall[i]) {
        colour = solid[i] ? cv::Vec3b(0, 220, 240) : cv::Vec3b(0, 0, 230);  // yellow / red
      }
      if (!occ && wall[i]) {
        colour = known ? cv::Vec3b(230, 90, 0) : cv::Vec3b(240, 200, 150);  // missed: blue
      }
      row[c] = colour;
    }
  }
  cv::Mat big;
  cv::resize(img, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
  return big;
}

}  // namespace epmap::mobile_mapping
