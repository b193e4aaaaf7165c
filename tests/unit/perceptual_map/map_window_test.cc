#include "perception/perceptual_map/map_window.h"

#include <gtest/gtest.h>

#include <limits>

namespace epmap::perceptual_map {
namespace {

const Eigen::AlignedBox2d kBox(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(2.0, 1.0));

bool Touches(double x1, double y1, double x2, double y2) {
  return SegmentTouchesBox({x1, y1}, {x2, y2}, kBox);
}

TEST(MapWindow, ASegmentWithAnEndInsideTouches) {
  EXPECT_TRUE(Touches(1.0, 0.5, 5.0, 5.0));
  EXPECT_TRUE(Touches(5.0, 5.0, 1.0, 0.5));
  EXPECT_TRUE(Touches(0.5, 0.2, 1.5, 0.8));  // wholly inside
}

TEST(MapWindow, ASegmentCrossingTheBoxWithBothEndsOutsideTouches) {
  EXPECT_TRUE(Touches(-1.0, 0.5, 3.0, 0.5));   // straight through
  EXPECT_TRUE(Touches(-0.5, -0.4, 2.5, 1.4));  // through a diagonal
  EXPECT_TRUE(Touches(1.0, -3.0, 1.0, 3.0));   // vertical
}

TEST(MapWindow, ASegmentOnTheEdgeTouchesAndOneJustPastItDoesNot) {
  EXPECT_TRUE(Touches(-1.0, 1.0, 3.0, 1.0));  // along the top edge
  EXPECT_TRUE(Touches(2.0, 1.0, 3.0, 3.0));   // ends on the corner (2, 1)
  EXPECT_FALSE(Touches(-1.0, 1.001, 3.0, 1.001));
  EXPECT_FALSE(Touches(2.001, -1.0, 2.001, 2.0));
}

TEST(MapWindow, ASegmentPassingBesideACornerDoesNotTouch) {
  // Both ends outside, its bounding box overlaps the box, but it misses the corner (2, 1).
  EXPECT_FALSE(Touches(1.5, 1.6, 2.6, 0.5));
  EXPECT_TRUE(Touches(1.5, 1.4, 2.4, 0.5));  // the same a little lower cuts the corner
}

TEST(MapWindow, APointSegmentTouchesWhenInside) {
  EXPECT_TRUE(Touches(1.0, 1.0, 1.0, 1.0));
  EXPECT_FALSE(Touches(3.0, 3.0, 3.0, 3.0));
}

TEST(MapWindow, NotANumberAndEmptyBoxesHoldNothing) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(Touches(nan, 0.5, 1.0, 0.5));
  const Eigen::AlignedBox2d empty;  // Eigen's default box is empty
  EXPECT_FALSE(SegmentTouchesBox({0.0, 0.0}, {1.0, 1.0}, empty));
}

TEST(MapWindow, SegmentsInBoxKeepsTheMapsOrderAndFields) {
  std::vector<MapSegment> map(3);
  map[0] = {7, {5.0, 5.0}, {6.0, 6.0}, 1, 1};
  map[1] = {3, {-1.0, 0.5}, {3.0, 0.5}, 2, 4};
  map[2] = {9, {0.5, 0.5}, {0.6, 0.6}, 3, 2};
  const auto in = SegmentsInBox(map, kBox);
  ASSERT_EQ(in.size(), 2u);
  EXPECT_EQ(in[0].id, 3u);
  EXPECT_EQ(in[0].observations, 4u);
  EXPECT_EQ(in[1].id, 9u);
}

}  // namespace
}  // namespace epmap::perceptual_map
