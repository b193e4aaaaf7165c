#pragma once
// Which segments of the perceptual map a window of the world frame holds: what a local planner
// asks for (GetPerceptualMapRequest region / around_robot_m) instead of every wall of a long run.

#include <Eigen/Geometry>
#include <vector>

#include "perception/perceptual_map/reference_objects.h"

namespace epmap::perceptual_map {

// True when some point of the segment a-b lies in the closed box (a segment crossing the box
// without an end inside it counts; one touching its edge too). An empty box holds nothing.
bool SegmentTouchesBox(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                       const Eigen::AlignedBox2d& box);

// The segments that SegmentTouchesBox, in the map's order.
std::vector<MapSegment> SegmentsInBox(const std::vector<MapSegment>& segments,
                                      const Eigen::AlignedBox2d& box);

}  // namespace epmap::perceptual_map
