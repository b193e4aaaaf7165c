// The perceptual map as visualization_msgs/MarkerArray (services/mapping/ros_output): what RViz
// draws, and that it goes through CDR and back unchanged.

#include "services/mapping/ros_output/perceptual_map_markers.h"

#include <epmap_dds/MarkerArray.h>
#include <epmap_dds/MarkerArrayPubSubTypes.h>
#include <gtest/gtest.h>

#include <fastdds/rtps/common/SerializedPayload.h>

namespace epmap::mapping {
namespace {

perceptual_map::PerceptualMap SmallMap() {
  perceptual_map::PerceptualMap map;
  map.segments.push_back({7, {1.0, 2.0}, {3.0, 2.0}, 1, 2});
  map.segments.push_back({9, {-1.5, 0.25}, {-1.5, 4.0}, 2, 1});
  map.path = {{0, 0}, {1, 0}, {1, 1}};
  map.boundary.outer = {{-2, -1}, {4, -1}};
  map.boundary.inner = {{0.5, 0.5}};  // one point: nothing to draw
  return map;
}

TEST(PerceptualMapMarkers, SegmentsPathAndBoundaryAreLinesOnTheFloorAfterADeleteAll) {
  visualization_msgs::msg::MarkerArray msg;
  ToRosMarkers(SmallMap(), 1'500'000'000, "map", &msg);
  ASSERT_EQ(msg.markers().size(), 4u);  // DELETEALL, segments, path, outer boundary
  EXPECT_EQ(msg.markers()[0].action(), kMarkerDeleteAll);
  EXPECT_EQ(msg.markers()[0].header().frame_id(), "map");

  const auto& lines = msg.markers()[1];
  EXPECT_EQ(lines.ns(), "segments");
  EXPECT_EQ(lines.type(), kMarkerLineList);
  EXPECT_EQ(lines.action(), kMarkerAdd);
  EXPECT_EQ(lines.header().stamp().sec(), 1);
  EXPECT_EQ(lines.header().stamp().nanosec(), 500'000'000u);
  EXPECT_DOUBLE_EQ(lines.pose().orientation().w(), 1.0);  // identity: points are in "map"
  EXPECT_GT(lines.scale().x(), 0.0);
  EXPECT_FLOAT_EQ(lines.color().a(), 1.0F);  // alpha 0 would be invisible
  ASSERT_EQ(lines.points().size(), 4u);      // two ends per segment, in the map's order
  EXPECT_DOUBLE_EQ(lines.points()[0].x(), 1.0);
  EXPECT_DOUBLE_EQ(lines.points()[1].x(), 3.0);
  EXPECT_DOUBLE_EQ(lines.points()[2].y(), 0.25);
  EXPECT_DOUBLE_EQ(lines.points()[3].y(), 4.0);
  for (const auto& p : lines.points()) EXPECT_EQ(p.z(), 0.0);

  EXPECT_EQ(msg.markers()[2].ns(), "path");
  EXPECT_EQ(msg.markers()[2].type(), kMarkerLineStrip);
  EXPECT_EQ(msg.markers()[2].points().size(), 3u);
  EXPECT_EQ(msg.markers()[3].ns(), "boundary");
  EXPECT_EQ(msg.markers()[3].id(), 0);
  EXPECT_EQ(msg.markers()[3].points().size(), 2u);

  visualization_msgs::msg::MarkerArray empty;
  ToRosMarkers({}, 0, "map", &empty);
  ASSERT_EQ(empty.markers().size(), 1u) << "an empty map only clears what RViz drew";
}

// The segments the redundancy removal keeps (paper 003 III-D) come last, in a namespace of
// their own that RViz can show alone.
TEST(PerceptualMapMarkers, TheKeptSegmentsAreANamespaceOfTheirOwn) {
  auto map = SmallMap();
  map.kept_segments = {map.segments[1]};
  visualization_msgs::msg::MarkerArray msg;
  ToRosMarkers(map, 1'500'000'000, "map", &msg);
  ASSERT_EQ(msg.markers().size(), 5u);
  const auto& kept = msg.markers()[4];
  EXPECT_EQ(kept.ns(), "kept_segments");
  EXPECT_EQ(kept.type(), kMarkerLineList);
  ASSERT_EQ(kept.points().size(), 2u);
  EXPECT_DOUBLE_EQ(kept.points()[0].x(), -1.5);
  EXPECT_DOUBLE_EQ(kept.points()[1].y(), 4.0);
  EXPECT_GT(kept.scale().x(), msg.markers()[1].scale().x()) << "drawn over the others";
}

TEST(PerceptualMapMarkers, TheMessageGoesThroughCdrUnchanged) {
  visualization_msgs::msg::MarkerArray msg;
  ToRosMarkers(SmallMap(), 42, "robot1_map", &msg);
  visualization_msgs::msg::MarkerArrayPubSubType type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(&msg)());
  ASSERT_TRUE(type.serialize(&msg, &payload));
  visualization_msgs::msg::MarkerArray back;
  ASSERT_TRUE(type.deserialize(&payload, &back));
  EXPECT_EQ(back, msg);
  EXPECT_EQ(type.getName(), std::string("visualization_msgs::msg::dds_::MarkerArray_"));
}

}  // namespace
}  // namespace epmap::mapping
