#include "perception/perceptual_map/boundary.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "perception/perceptual_map/box_grid.h"

namespace epmap::perceptual_map {

void BoundaryParams::Validate() const {
  if (objects_per_side < 1) throw std::invalid_argument("boundary: objects_per_side must be >= 1");
  if (!(max_distance_m > 0)) throw std::invalid_argument("boundary: max_distance_m must be > 0");
  if (!(path_sample_m > 0)) throw std::invalid_argument("boundary: path_sample_m must be > 0");
  if (!(index_cell_m >= 0) || !std::isfinite(index_cell_m)) {
    throw std::invalid_argument("boundary: index_cell_m must be >= 0 and finite");
  }
}

namespace {

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

Eigen::AlignedBox2d BoxOf(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  Eigen::AlignedBox2d box(a);
  box.extend(b);
  return box;
}

Eigen::AlignedBox2d BoxAround(const Eigen::Vector2d& q, double radius) {
  return {q - Eigen::Vector2d::Constant(radius), q + Eigen::Vector2d::Constant(radius)};
}

// The path without repeated points (stops), as lines with their arc length, indexed by cell.
struct PathLines {
  std::vector<Eigen::Vector2d> points;
  std::vector<double> arc;                 // arc length at each point
  std::vector<Eigen::AlignedBox2d> boxes;  // of each line
  BoxGrid index;                           // line i spans points[i], points[i + 1]
  double cell_m;

  PathLines(const std::vector<Eigen::Vector2d>& path, double index_cell_m)
      : index(index_cell_m), cell_m(index_cell_m) {
    for (const auto& p : path) {
      if (!p.allFinite()) continue;
      if (points.empty() || (p - points.back()).norm() > 1e-6) {
        arc.push_back(points.empty() ? 0.0 : arc.back() + (p - points.back()).norm());
        points.push_back(p);
      }
    }
    for (size_t i = 0; i < lines(); ++i) {
      boxes.push_back(BoxOf(points[i], points[i + 1]));
      index.Add(static_cast<uint32_t>(i), boxes.back());
    }
  }
  size_t lines() const { return points.size() < 2 ? 0 : points.size() - 1; }

  // The lines whose box may meet `box`, in no particular order.
  void Near(const Eigen::AlignedBox2d& box, std::vector<uint32_t>* out) const {
    index.Query(box, out);
  }

  // Nearest point of the path to q: line index, arc length there, signed side (> 0 = left).
  // Of lines at the same distance, the first.
  struct Projection {
    size_t line = 0;
    double arc = 0;
    double distance = std::numeric_limits<double>::infinity();
    double side = 0;
  };
  Projection Project(const Eigen::Vector2d& q) const {
    Projection best;
    if (!q.allFinite() || lines() == 0) return best;
    // Squares around q: a line outside a square of half-width r is at least r away, so once
    // the nearest line inside is nearer than r, no line outside can beat or tie it. When the
    // square holds lines but none that near, the next one is just wide enough to hold every
    // line as near as the nearest found, which settles the search.
    // A floor driven many times has dozens of path lines in every cell: a line whose box is
    // farther than the nearest so far is not projected at all, and one that lies farther gets
    // no square root.
    std::vector<uint32_t> near;
    for (double r = cell_m > 0 ? cell_m : 1.0;;) {
      const auto box = BoxAround(q, r);
      Near(box, &near);
      best = Projection{};
      double best_d2 = std::numeric_limits<double>::infinity();
      for (const uint32_t i : near) {
        if (boxes[i].squaredExteriorDistance(q) > best_d2 * (1 + 1e-9) + 1e-18) continue;
        const Eigen::Vector2d a = points[i];
        const Eigen::Vector2d d = points[i + 1] - a;
        const double t = std::clamp((q - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
        const double d2 = (q - (a + t * d)).squaredNorm();
        if (d2 > best_d2 * (1 + 1e-9) + 1e-18) continue;  // cannot beat or tie the nearest
        // Ties are decided on the distance itself: a path driven back over itself has each
        // line twice, the second reversed, and their squared distances may differ in the last
        // bit where the distances do not; the first line wins, whatever the rounding.
        const double dist = std::sqrt(d2);
        if (dist < best.distance || (dist == best.distance && i < best.line)) {
          best_d2 = d2;
          best.distance = dist;
          best.line = i;
          best.arc = arc[i] + t * d.norm();
          best.side = Cross(d, q - a);
        }
      }
      if (best.distance < r || index.Covers(box)) return best;
      r = std::isfinite(best.distance) ? best.distance * (1 + 1e-9) + 1e-12 : 2 * r;
    }
  }

  // Sum of the signed turns between successive lines: > 0 when the path turns left overall.
  double NetTurn() const {
    double turn = 0;
    for (size_t i = 1; i < lines(); ++i) {
      const Eigen::Vector2d d0 = points[i] - points[i - 1];
      const Eigen::Vector2d d1 = points[i + 1] - points[i];
      turn += std::atan2(Cross(d0, d1), d0.dot(d1));
    }
    return turn;
  }
};

}  // namespace

bool SegmentsIntersect(const Eigen::Vector2d& a1, const Eigen::Vector2d& a2,
                       const Eigen::Vector2d& b1, const Eigen::Vector2d& b2) {
  const auto orient = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                         const Eigen::Vector2d& r) { return Cross(q - p, r - p); };
  const auto on_segment = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                             const Eigen::Vector2d& r) {
    return std::min(p.x(), q.x()) - 1e-12 <= r.x() && r.x() <= std::max(p.x(), q.x()) + 1e-12 &&
           std::min(p.y(), q.y()) - 1e-12 <= r.y() && r.y() <= std::max(p.y(), q.y()) + 1e-12;
  };
  const double d1 = orient(b1, b2, a1), d2 = orient(b1, b2, a2);
  const double d3 = orient(a1, a2, b1), d4 = orient(a1, a2, b2);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) {
    return true;
  }
  return (d1 == 0 && on_segment(b1, b2, a1)) || (d2 == 0 && on_segment(b1, b2, a2)) ||
         (d3 == 0 && on_segment(a1, a2, b1)) || (d4 == 0 && on_segment(a1, a2, b2));
}

double PointSegmentDistance(const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                            const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = b - a;
  const double n = d.squaredNorm();
  if (n <= 0) return (q - a).norm();
  const double t = std::clamp((q - a).dot(d) / n, 0.0, 1.0);
  return (q - (a + t * d)).norm();
}

Boundary ComputeBoundary(const std::vector<MapSegment>& segments,
                         const std::vector<Eigen::Vector2d>& path, const BoundaryParams& params) {
  params.Validate();
  Boundary out;
  const PathLines lines(path, params.index_cell_m);

  // 1. Objects crossing the path are not surfaces: the robot drove through them.
  std::vector<const MapSegment*> candidates;
  std::vector<uint32_t> near_lines;
  for (const auto& s : segments) {
    bool crosses = false;
    lines.Near(BoxOf(s.a, s.b), &near_lines);
    for (size_t k = 0; k < near_lines.size() && !crosses; ++k) {
      const size_t i = near_lines[k];
      crosses = SegmentsIntersect(s.a, s.b, lines.points[i], lines.points[i + 1]);
    }
    if (crosses) {
      out.removed_on_path.push_back(s.id);
    } else {
      candidates.push_back(&s);
    }
  }

  // 2. Inner and outer: the side of the path each object lies on. Inner is the side the path
  // turns towards overall (the inside of a loop); for a straight path, the left.
  out.inner_is_left = lines.NetTurn() >= 0;
  // Placing an object (its nearest path line) costs more than anything else here on a floor
  // driven many times, and most objects are never among a path point's nearest: each object
  // is placed when step 3 first needs its side.
  struct Placed {
    const MapSegment* segment;
    bool resolved = false;
    bool inner = false;
    double arc = 0;
  };
  std::vector<Placed> placed;
  for (const MapSegment* s : candidates) placed.push_back({s});
  const auto resolve = [&](Placed& p) -> const Placed& {
    if (!p.resolved) {
      const auto proj = lines.Project(p.segment->a * 0.5 + p.segment->b * 0.5);
      p.inner = (proj.side > 0) == out.inner_is_left;
      p.arc = proj.arc;
      p.resolved = true;
    }
    return p;
  };
  if (lines.lines() == 0) {
    for (const auto& p : placed) out.outer_ids.push_back(p.segment->id);
    for (const auto& p : placed) {
      out.outer.push_back(p.segment->a);
      out.outer.push_back(p.segment->b);
    }
    return out;
  }

  // 3. For each point along the path, the nearest objects on each side are kept.
  std::set<const MapSegment*> kept;
  std::vector<Eigen::Vector2d> samples;
  for (size_t i = 0; i < lines.lines(); ++i) {
    const Eigen::Vector2d a = lines.points[i];
    const Eigen::Vector2d d = lines.points[i + 1] - a;
    const int n = std::max(1, static_cast<int>(std::ceil(d.norm() / params.path_sample_m)));
    for (int k = 0; k < n; ++k) samples.push_back(a + d * (static_cast<double>(k) / n));
  }
  samples.push_back(lines.points.back());
  BoxGrid placed_index(params.index_cell_m);
  std::vector<Eigen::AlignedBox2d> placed_box;
  for (size_t k = 0; k < placed.size(); ++k) {
    placed_box.push_back(BoxOf(placed[k].segment->a, placed[k].segment->b));
    placed_index.Add(static_cast<uint32_t>(k), placed_box.back());
  }
  // Per side, the nearest objects found so far, ordered by (distance, object): the first
  // per_side of all the objects within max_d in that order, as sorting them all would give.
  using Nearest = std::pair<double, const MapSegment*>;
  std::vector<Nearest> nearest[2];
  std::vector<uint32_t> near_placed;
  const size_t per_side = static_cast<size_t>(params.objects_per_side);
  const double max_d = params.max_distance_m;
  // The previous path point's farthest kept object and where that point was: its nearest few
  // on each side are at most that far plus the step from it (a distance to a segment changes
  // no faster than the point moves), so a square that wide around the next point settles it in
  // one look. On a dense map that square is much smaller than a cell. (Any first square gives
  // the same answer, the loop below widens it until settled; this one saves looks and
  // candidates.) -1: the previous point did not fill both sides.
  double previous_worst = -1;
  Eigen::Vector2d previous_q = Eigen::Vector2d::Zero();
  for (const auto& q : samples) {
    // Squares of growing half-width r around q: an object outside the square is at least r
    // away, so once each side has its nearest few nearer than r, no object outside can beat or
    // tie them. The first square is one cell, or the one the previous point's objects settle
    // (above) if smaller; when both sides have their few but not all nearer than r, the next square
    // is just wide enough to hold every object as near as they are. An object within max_d has its
    // box within the square of half-width max_d.
    double first_r = params.index_cell_m > 0 ? std::min(params.index_cell_m, max_d) : max_d;
    if (previous_worst >= 0) {
      first_r = std::min(first_r, (previous_worst + (q - previous_q).norm()) * (1 + 1e-9) + 1e-9);
    }
    for (double r = first_r;;) {
      nearest[0].clear();
      nearest[1].clear();
      placed_index.Query(BoxAround(q, r), &near_placed);
      // An object whose box is farther than a full side's last kept one cannot displace it
      // (its distance is at least the box's): most candidates of a dense map stop here, without
      // their distance, and if farther than both sides' last ones, without their side either.
      // The margin keeps rounding from dropping a tie.
      const auto beyond = [&](uint32_t k, const std::vector<Nearest>& side) {
        if (side.size() < per_side) return false;
        const double worst = side.back().first;
        return placed_box[k].squaredExteriorDistance(q) > worst * worst * (1 + 1e-9) + 1e-18;
      };
      for (const uint32_t k : near_placed) {
        if (!placed[k].resolved && beyond(k, nearest[0]) && beyond(k, nearest[1])) continue;
        auto& side = nearest[resolve(placed[k]).inner ? 1 : 0];
        if (beyond(k, side)) continue;
        const MapSegment* s = placed[k].segment;
        const Nearest candidate{PointSegmentDistance(q, s->a, s->b), s};
        if (!(candidate.first <= max_d)) continue;  // also a segment that is not finite
        if (side.size() == per_side && !(candidate < side.back())) continue;
        if (side.size() == per_side) side.pop_back();
        side.insert(std::upper_bound(side.begin(), side.end(), candidate), candidate);
      }
      const auto settled = [&](const std::vector<Nearest>& side) {
        return side.size() == per_side && side.back().first < r;
      };
      if (r >= max_d || (settled(nearest[0]) && settled(nearest[1]))) break;
      const bool both_full = nearest[0].size() == per_side && nearest[1].size() == per_side;
      r = std::min(
          both_full
              ? std::max(nearest[0].back().first, nearest[1].back().first) * (1 + 1e-9) + 1e-12
              : 2 * r,
          max_d);
    }
    for (const auto& side : nearest) {
      for (const auto& [d, s] : side) kept.insert(s);
    }
    const bool both_full = nearest[0].size() == per_side && nearest[1].size() == per_side;
    previous_worst = both_full ? std::max(nearest[0].back().first, nearest[1].back().first) : -1.0;
    previous_q = q;
  }

  // 4. Boundary: the kept objects of each side in the order the path passes them, each one's
  // end points in that order too, joined from one object to the next.
  // Only the kept ones are ordered (a floor driven again keeps a few of many); objects the
  // path passes at the same arc length go by id, so the order never depends on the sort.
  std::vector<Placed> ordered;
  for (const auto& p : placed) {
    if (kept.count(p.segment)) ordered.push_back(p);  // resolved in step 3
  }
  std::sort(ordered.begin(), ordered.end(), [](const Placed& x, const Placed& y) {
    return x.arc != y.arc ? x.arc < y.arc : x.segment->id < y.segment->id;
  });
  for (const auto& p : ordered) {
    auto& ids = p.inner ? out.inner_ids : out.outer_ids;
    auto& line = p.inner ? out.inner : out.outer;
    ids.push_back(p.segment->id);
    const bool a_first = lines.Project(p.segment->a).arc <= lines.Project(p.segment->b).arc;
    line.push_back(a_first ? p.segment->a : p.segment->b);
    line.push_back(a_first ? p.segment->b : p.segment->a);
  }
  return out;
}

}  // namespace epmap::perceptual_map
