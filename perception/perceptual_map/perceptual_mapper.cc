#include "perception/perceptual_map/perceptual_mapper.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>

namespace epmap::perceptual_map {

double Heading(const Eigen::Isometry2d& T) {
  return std::atan2(T.linear()(1, 0), T.linear()(0, 0));
}

void PerceptualMapParams::Validate() const {
  clustering.Validate();
  boundary.Validate();
  if (!(track_max_distance_m > 0)) {
    throw std::invalid_argument("perceptual map: track_max_distance_m must be > 0");
  }
  if (!(track_max_angle_rad > 0)) {
    throw std::invalid_argument("perceptual map: track_max_angle_rad must be > 0");
  }
  if (min_tracked < 1) throw std::invalid_argument("perceptual map: min_tracked must be >= 1");
  if (!(anchor_length_agreement > 0 && anchor_length_agreement <= 1)) {
    throw std::invalid_argument("perceptual map: anchor_length_agreement must be in (0, 1]");
  }
  if (!(anchor_motion_tolerance_m >= 0)) {
    throw std::invalid_argument("perceptual map: anchor_motion_tolerance_m must be >= 0");
  }
  if (!(anchor_search_m >= 0)) {
    throw std::invalid_argument("perceptual map: anchor_search_m must be >= 0");
  }
}

namespace {

// Revisions are drawn from one counter for every mapper in the process, so a mapper replaced
// by a new one (a reset) never repeats the revision a caller cached.
uint64_t NextRevision() {
  static std::atomic<uint64_t> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

// The map's segment with this id, or nullptr. Segments are appended with increasing ids and
// never removed (Restore checks it), so a binary search finds one: a hash index of the whole
// map, rebuilt for every view, cost O(map) per view on the mapping thread (22 237 segments
// after twelve passes of one floor).
template <class Segments>
auto FindSegment(Segments& segments, int64_t id) -> decltype(&segments[0]) {
  const auto it = std::lower_bound(
      segments.begin(), segments.end(), id,
      [](const MapSegment& s, int64_t wanted) { return static_cast<int64_t>(s.id) < wanted; });
  return it != segments.end() && static_cast<int64_t>(it->id) == id ? &*it : nullptr;
}

}  // namespace

PerceptualMapper::PerceptualMapper(const PerceptualMapParams& params)
    : params_(params), revision_(NextRevision()) {
  params_.Validate();
}

PerceptualMapper::State PerceptualMapper::SavedState() const {
  State s;
  s.segments = segments_;
  s.views = views_;
  s.has_latest = has_latest_;
  s.latest_record = latest_.record;
  s.latest_objects = latest_.objects;
  s.latest_global_id = latest_.global_id;
  s.last_map_view = last_map_view_;
  s.next_id = next_id_;
  s.skipped_views = skipped_views_;
  s.expansions = expansions_;
  s.last_stamp_ns = last_stamp_ns_;
  return s;
}

void PerceptualMapper::Restore(State s) {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("perceptual map: saved state does not hold together: " + what);
  };
  for (size_t i = 0; i < s.segments.size(); ++i) {
    const auto& g = s.segments[i];
    if (!g.a.allFinite() || !g.b.allFinite()) fail("a segment is not finite");
    if (g.id == 0 || g.id >= s.next_id) fail("segment id " + std::to_string(g.id));
    if (i > 0 && g.id <= s.segments[i - 1].id) fail("segment ids not increasing");
  }
  for (const auto& v : s.views) {
    if (!v.T_world_base.matrix().allFinite() || !v.T_map_base.matrix().allFinite()) {
      fail("a view's pose is not finite");
    }
  }
  if (s.has_latest && s.latest_record >= s.views.size()) fail("the newest view is not a view");
  if (!s.views.empty() && s.last_map_view >= s.views.size()) fail("the last map view");
  if (s.latest_global_id.size() != s.latest_objects.size()) fail("ids per object");
  for (const auto& o : s.latest_objects) {
    if (!o.a.allFinite() || !o.b.allFinite()) fail("an object is not finite");
  }
  for (const int64_t id : s.latest_global_id) {
    if (id < -1 || id >= static_cast<int64_t>(s.next_id)) fail("object id " + std::to_string(id));
  }
  revision_ = NextRevision();
  segments_ = std::move(s.segments);
  views_ = std::move(s.views);
  has_latest_ = s.has_latest;
  latest_.record = s.latest_record;
  latest_.objects = std::move(s.latest_objects);
  latest_.global_id = std::move(s.latest_global_id);
  last_map_view_ = static_cast<size_t>(s.last_map_view);
  next_id_ = s.next_id;
  skipped_views_ = static_cast<size_t>(s.skipped_views);
  expansions_ = static_cast<size_t>(s.expansions);
  last_stamp_ns_ = s.last_stamp_ns;
}

namespace {

// Angle between two undirected lines, in [0, pi/2].
double LineAngle(const Eigen::Vector2d& d1, const Eigen::Vector2d& d2) {
  const double c = std::abs(d1.normalized().dot(d2.normalized()));
  return std::acos(std::min(1.0, c));
}

double PerpendicularDistance(const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                             const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = (b - a).normalized();
  const Eigen::Vector2d r = q - a;
  return std::abs(d.x() * r.y() - d.y() * r.x());
}

}  // namespace

AddViewResult PerceptualMapper::AddView(int64_t stamp_ns,
                                        const std::vector<Eigen::Vector2d>& points_base,
                                        const Eigen::Isometry2d& T_world_base) {
  if (!T_world_base.matrix().allFinite()) {
    throw std::invalid_argument("perceptual map: the view's pose is not finite");
  }
  if (!views_.empty() && stamp_ns < last_stamp_ns_) {
    throw std::invalid_argument("perceptual map: view stamp " + std::to_string(stamp_ns) +
                                " is older than the previous view's " +
                                std::to_string(last_stamp_ns_));
  }
  AddViewResult result;
  ViewState cur;
  cur.objects = FitReferenceObjects(points_base, T_world_base, params_.clustering);
  result.objects = cur.objects.size();
  if (cur.objects.empty()) {
    // Nothing to track or add (a blank view): the map and the tracked objects stay as they are.
    ++skipped_views_;
    result.skipped = true;
    return result;
  }
  revision_ = NextRevision();
  last_stamp_ns_ = stamp_ns;
  cur.global_id.assign(cur.objects.size(), -1);
  cur.record = static_cast<uint32_t>(views_.size());
  MapView record;
  record.id = cur.record + 1;
  record.stamp_ns = stamp_ns;
  record.T_world_base = T_world_base;
  record.objects = static_cast<uint32_t>(cur.objects.size());
  views_.push_back(record);
  result.view_id = record.id;

  if (!has_latest_) {
    // V_0 initialises the perceptual map (Sec. II): its frame places the map in the world.
    MapView& v = views_.back();
    v.in_map = true;
    v.T_map_base = T_world_base;
    for (size_t k = 0; k < cur.objects.size(); ++k) {
      const uint32_t id = next_id_++;
      cur.global_id[k] = id;
      segments_.push_back(
          {id, T_world_base * cur.objects[k].a, T_world_base * cur.objects[k].b, v.id, 1});
    }
    last_map_view_ = cur.record;
    latest_ = std::move(cur);
    has_latest_ = true;
    return result;
  }

  ViewState prev = latest_;
  size_t tracked = Track(prev, &cur);
  if (tracked < static_cast<size_t>(params_.min_tracked) && !views_[prev.record].in_map) {
    // II step iii: the robot has left the local environment; V_{n-1} joins the map and its
    // objects become the new reference objects R.
    Expand(&prev, &segments_, &views_, &next_id_, last_map_view_);
    last_map_view_ = prev.record;
    ++expansions_;
    result.expanded = true;
    std::fill(cur.global_id.begin(), cur.global_id.end(), -1);
    tracked = Track(prev, &cur);
  }
  // Where the new view is in the map: the last map view's placement and the motion since.
  const MapView& anchor = views_[last_map_view_];
  views_[cur.record].T_map_base =
      anchor.T_map_base * (anchor.T_world_base.inverse() * T_world_base);
  views_[cur.record].tracked = static_cast<uint32_t>(tracked);
  for (int64_t id : cur.global_id) {
    if (MapSegment* s = FindSegment(segments_, id)) ++s->observations;
  }
  result.tracked = tracked;
  latest_ = std::move(cur);
  return result;
}

size_t PerceptualMapper::Track(const ViewState& prev, ViewState* cur) const {
  // Eq. 5: [x' z' 1] = [x z 1] * (3x3 motion of the robot from the previous view).
  const Eigen::Isometry2d T_cur_prev =
      views_[cur->record].T_world_base.inverse() * views_[prev.record].T_world_base;
  struct Candidate {
    double cost;
    size_t i, j;
  };
  std::vector<Candidate> candidates;
  for (size_t i = 0; i < prev.objects.size(); ++i) {
    if (prev.global_id[i] < 0) continue;  // only reference objects of the map are tracked
    const Eigen::Vector2d a = T_cur_prev * prev.objects[i].a;
    const Eigen::Vector2d b = T_cur_prev * prev.objects[i].b;
    const Eigen::Vector2d mid = 0.5 * (a + b);
    for (size_t j = 0; j < cur->objects.size(); ++j) {
      const auto& o = cur->objects[j];
      if (LineAngle(b - a, o.b - o.a) > params_.track_max_angle_rad) continue;
      // Extents differ between views (occlusion, field of view): the midpoint of one line on
      // the other one is enough, provided the two lines are also close across.
      const double along =
          std::min(PointSegmentDistance(o.mid(), a, b), PointSegmentDistance(mid, o.a, o.b));
      const double across = PerpendicularDistance(o.mid(), a, b);
      if (along > params_.track_max_distance_m || across > params_.track_max_distance_m) continue;
      candidates.push_back({along + across, i, j});
    }
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& x, const Candidate& y) { return x.cost < y.cost; });
  std::vector<bool> used_prev(prev.objects.size(), false);
  std::vector<bool> used_cur(cur->objects.size(), false);
  size_t tracked = 0;
  for (const auto& c : candidates) {
    if (used_prev[c.i] || used_cur[c.j]) continue;
    used_prev[c.i] = used_cur[c.j] = true;
    cur->global_id[c.j] = prev.global_id[c.i];
    ++tracked;
  }
  return tracked;
}

void PerceptualMapper::Expand(ViewState* view, std::vector<MapSegment>* segments,
                              std::vector<MapView>* views, uint32_t* next_id,
                              size_t last_map_view) const {
  MapView& record = (*views)[view->record];
  const double theta = Heading(record.T_world_base);  // accumulated turn (III-C step iv)
  const Eigen::Rotation2Dd R(theta);

  // III-C steps i-iii: the common tracked objects, each with its end point in the view (L_pv)
  // and the same end point in the global map (L_gm). "Left" end point: the one first along the
  // global segment's direction, so both copies name the same physical end.
  struct Common {
    size_t k;
    Eigen::Vector2d end_view;  // L_pv, view frame
    Eigen::Vector2d end_map;   // L_gm, map frame
    bool agrees;               // same extent in the view and in the map
  };
  std::vector<Common> common;
  // Where the robot's motion since the last map view puts this view (the check on anchors).
  const MapView& last = (*views)[last_map_view];
  const Eigen::Isometry2d T_by_motion =
      last.T_map_base * (last.T_world_base.inverse() * record.T_world_base);
  for (size_t k = 0; k < view->objects.size(); ++k) {
    const int64_t id = view->global_id[k];
    const MapSegment* found = FindSegment(*segments, id);
    if (!found) continue;
    const MapSegment& g = *found;
    const auto& o = view->objects[k];
    const Eigen::Vector2d dir = g.b - g.a;
    const bool a_first = (R * o.a).dot(dir) <= (R * o.b).dot(dir);
    const double lo = std::min(o.length(), g.length());
    const double hi = std::max(o.length(), g.length());
    const Eigen::Vector2d end_view = a_first ? o.a : o.b;
    if (params_.anchor_motion_tolerance_m > 0) {
      // Not the same physical end point in the view and in the map (the wall was cut elsewhere
      // or seen shorter): it would place the view, and all it adds, off by the difference.
      const Eigen::Vector2d implied = g.a - R * end_view;  // the view's position it implies
      if ((implied - T_by_motion.translation()).norm() > params_.anchor_motion_tolerance_m) {
        continue;
      }
    }
    common.push_back({k, end_view, g.a, hi > 0 && lo / hi >= params_.anchor_length_agreement});
  }

  if (common.empty() || params_.place_by_pose) {
    // No common object to triangulate from (or none consistent with the motion): the view is
    // placed by the robot's motion from the last map view (the situation the paper avoids by
    // adding V_{n-1}, counted here).
    record.T_map_base = T_by_motion;
    record.placed_by_pose = true;
  } else {
    // The view's position in the map (for the path): the median of the translations the
    // agreeing common objects imply, all common objects if none agrees.
    std::vector<double> tx, ty;
    const bool any_agrees =
        std::any_of(common.begin(), common.end(), [](const Common& c) { return c.agrees; });
    for (const auto& c : common) {
      if (any_agrees && !c.agrees) continue;
      const Eigen::Vector2d t = c.end_map - R * c.end_view;
      tx.push_back(t.x());
      ty.push_back(t.y());
    }
    const auto median = [](std::vector<double> v) {
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
      return v[v.size() / 2];
    };
    record.T_map_base = Eigen::Isometry2d::Identity();
    record.T_map_base.linear() = R.toRotationMatrix();
    record.T_map_base.translation() = Eigen::Vector2d(median(tx), median(ty));
  }

  for (size_t k = 0; k < view->objects.size(); ++k) {
    if (FindSegment(*segments, view->global_id[k])) continue;  // tracked: already in the map
    const auto& o = view->objects[k];
    Eigen::Vector2d a, b;
    if (common.empty() || params_.place_by_pose) {
      a = record.T_map_base * o.a;
      b = record.T_map_base * o.b;
    } else {
      // Nearest common object; a better-agreeing one a little farther is preferred.
      double nearest = std::numeric_limits<double>::infinity();
      std::vector<std::pair<double, const Common*>> by_distance;
      for (const auto& c : common) {
        const auto& co = view->objects[c.k];
        const double d = PointSegmentDistance(o.mid(), co.a, co.b);
        nearest = std::min(nearest, d);
        by_distance.emplace_back(d, &c);
      }
      std::sort(by_distance.begin(), by_distance.end(),
                [](const auto& x, const auto& y) { return x.first < y.first; });
      const Common* anchor = by_distance.front().second;
      for (const auto& [d, c] : by_distance) {
        if (d > nearest + params_.anchor_search_m) break;
        if (c->agrees) {
          anchor = c;
          break;
        }
      }
      // III-C step iv: vector v_i and angle theta_i from L_pv, turned by the accumulated turn,
      // laid from L_gm. (The paper subtracts a clockwise turn; ours is counter-clockwise.)
      a = anchor->end_map + R * (o.a - anchor->end_view);
      b = anchor->end_map + R * (o.b - anchor->end_view);
    }
    const uint32_t id = (*next_id)++;
    view->global_id[k] = id;
    segments->push_back({id, a, b, record.id, 1});
  }
  record.in_map = true;
}

PerceptualMap PerceptualMapper::Map(bool include_latest_view) const {
  PerceptualMap map;
  map.segments = segments_;
  map.views = views_;
  if (include_latest_view && has_latest_ && !views_[latest_.record].in_map) {
    ViewState latest = latest_;
    uint32_t next_id = next_id_;
    Expand(&latest, &map.segments, &map.views, &next_id, last_map_view_);
  }
  if (!map.views.empty()) map.stamp_ns = map.views.back().stamp_ns;
  for (const auto& v : map.views) map.path.push_back(v.T_map_base.translation());
  map.boundary = ComputeBoundary(map.segments, map.path, params_.boundary);
  std::set<uint32_t> kept(map.boundary.inner_ids.begin(), map.boundary.inner_ids.end());
  kept.insert(map.boundary.outer_ids.begin(), map.boundary.outer_ids.end());
  for (const auto& s : map.segments) {
    if (kept.count(s.id)) map.kept_segments.push_back(s);
  }
  return map;
}

}  // namespace epmap::perceptual_map
