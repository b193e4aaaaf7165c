#pragma once
// The perceptual map (paper 003) as visualization_msgs/MarkerArray, so RViz draws it over the
// occupancy grid without a client of ours: the global segments as one LINE_LIST, the path and
// the outer / inner boundary as LINE_STRIPs, all on the floor (z = 0) of `frame`. The array
// opens with a DELETEALL marker, so that a namespace that has emptied (no boundary yet) does
// not leave an old drawing behind.

#include <cstdint>
#include <string>

#include "perception/perceptual_map/perceptual_mapper.h"

namespace visualization_msgs::msg {
class MarkerArray;
}

namespace epmap::mapping {

// Marker types and actions of visualization_msgs/Marker.
inline constexpr int32_t kMarkerLineStrip = 4;
inline constexpr int32_t kMarkerLineList = 5;
inline constexpr int32_t kMarkerAdd = 0;
inline constexpr int32_t kMarkerDeleteAll = 3;

void ToRosMarkers(const perceptual_map::PerceptualMap& map, int64_t stamp_ns,
                  const std::string& frame, visualization_msgs::msg::MarkerArray* out);

}  // namespace epmap::mapping
