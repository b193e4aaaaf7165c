#include "services/mapping/ros_output/perceptual_map_markers.h"

#include <epmap_dds/MarkerArray.h>

#include <vector>

#include "common/dds/ros_conversions.h"

namespace epmap::mapping {
namespace {

struct Style {
  const char* ns;
  int32_t type;
  double width_m;  // scale.x: the line width for line markers
  float r, g, b;
};

// Colours as the benchmark's pmap.svg: segments blue, path green, boundary orange.
constexpr Style kSegments{"segments", kMarkerLineList, 0.05, 0.15F, 0.35F, 0.9F};
constexpr Style kPath{"path", kMarkerLineStrip, 0.03, 0.1F, 0.65F, 0.2F};
constexpr Style kBoundary{"boundary", kMarkerLineStrip, 0.03, 1.0F, 0.5F, 0.0F};
// The segments paper 003's redundancy removal keeps (III-D), drawn wider over the others: RViz
// can show this namespace alone for the clean map of the paper's Fig. 10.
constexpr Style kKeptSegments{"kept_segments", kMarkerLineList, 0.08, 0.6F, 0.05F, 0.05F};

visualization_msgs::msg::Marker Lines(const Style& style, int32_t id, int64_t stamp_ns,
                                      const std::string& frame,
                                      const std::vector<Eigen::Vector2d>& points) {
  visualization_msgs::msg::Marker m;
  m.header().stamp(dds::FromNanoseconds(stamp_ns));
  m.header().frame_id(frame);
  m.ns(style.ns);
  m.id(id);
  m.type(style.type);
  m.action(kMarkerAdd);
  m.pose().orientation().w(1.0);
  m.scale().x(style.width_m);
  m.color().r(style.r);
  m.color().g(style.g);
  m.color().b(style.b);
  m.color().a(1.0F);
  m.points().reserve(points.size());
  for (const auto& p : points) {
    geometry_msgs::msg::Point q;
    q.x(p.x());
    q.y(p.y());
    m.points().push_back(q);
  }
  return m;
}

// Both ends of every segment, in order: a LINE_LIST's points.
std::vector<Eigen::Vector2d> Ends(const std::vector<perceptual_map::MapSegment>& segments) {
  std::vector<Eigen::Vector2d> ends;
  ends.reserve(2 * segments.size());
  for (const auto& s : segments) {
    ends.push_back(s.a);
    ends.push_back(s.b);
  }
  return ends;
}

}  // namespace

void ToRosMarkers(const perceptual_map::PerceptualMap& map, int64_t stamp_ns,
                  const std::string& frame, visualization_msgs::msg::MarkerArray* out) {
  auto& markers = out->markers();
  markers.clear();
  visualization_msgs::msg::Marker clear;
  clear.header().stamp(dds::FromNanoseconds(stamp_ns));
  clear.header().frame_id(frame);
  clear.action(kMarkerDeleteAll);
  markers.push_back(clear);

  // A line marker needs two points at least; an empty set is simply not drawn.
  if (!map.segments.empty()) {
    markers.push_back(Lines(kSegments, 0, stamp_ns, frame, Ends(map.segments)));
  }
  if (map.path.size() >= 2) markers.push_back(Lines(kPath, 0, stamp_ns, frame, map.path));
  if (map.boundary.outer.size() >= 2) {
    markers.push_back(Lines(kBoundary, 0, stamp_ns, frame, map.boundary.outer));
  }
  if (map.boundary.inner.size() >= 2) {
    markers.push_back(Lines(kBoundary, 1, stamp_ns, frame, map.boundary.inner));
  }
  if (!map.kept_segments.empty()) {
    markers.push_back(Lines(kKeptSegments, 0, stamp_ns, frame, Ends(map.kept_segments)));
  }
}

}  // namespace epmap::mapping
