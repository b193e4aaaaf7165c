#include <gtest/gtest.h>

#include <algorithm>

#include "perception/perceptual_map/boundary.h"

namespace epmap {
namespace {

using perceptual_map::MapSegment;

std::vector<MapSegment> Square(double lo, double hi, uint32_t first_id) {
  const Eigen::Vector2d c[4] = {{lo, lo}, {hi, lo}, {hi, hi}, {lo, hi}};
  std::vector<MapSegment> out;
  for (uint32_t i = 0; i < 4; ++i) out.push_back({first_id + i, c[i], c[(i + 1) % 4], 1, 1});
  return out;
}

bool Has(const std::vector<uint32_t>& ids, uint32_t id) {
  return std::find(ids.begin(), ids.end(), id) != ids.end();
}

TEST(Boundary, InnerAndOuterObjectsAlongALoopAndObjectsOnThePathRemoved) {
  auto segments = Square(2, 8, 1);  // inner walls, ids 1-4
  auto outer = Square(-2, 12, 11);  // outer walls, ids 11-14
  segments.insert(segments.end(), outer.begin(), outer.end());
  segments.push_back({20, {5, -1}, {5, 1}, 1, 1});       // across the path: not a surface
  segments.push_back({21, {-1.5, 5}, {-1.5, 6}, 1, 1});  // behind... still outer, but farther
  const std::vector<Eigen::Vector2d> path = {{0, 0}, {10, 0}, {10, 10}, {0, 10}, {0, 0}};
  perceptual_map::BoundaryParams p;
  p.objects_per_side = 1;
  const auto b = perceptual_map::ComputeBoundary(segments, path, p);
  EXPECT_TRUE(b.inner_is_left);  // counter-clockwise loop: the inside is on the left
  EXPECT_EQ(b.removed_on_path, std::vector<uint32_t>{20});
  for (uint32_t id : {1u, 2u, 3u, 4u}) EXPECT_TRUE(Has(b.inner_ids, id)) << id;
  for (uint32_t id : {11u, 12u, 13u, 14u}) EXPECT_TRUE(Has(b.outer_ids, id)) << id;
  EXPECT_FALSE(Has(b.inner_ids, 11));
  // The nearest object per side is kept: 21 is nearer than wall 14 where the path passes it.
  EXPECT_TRUE(Has(b.outer_ids, 21));
  // Boundaries are polylines through the kept objects' end points, in path order.
  EXPECT_EQ(b.inner.size(), 2 * b.inner_ids.size());
  EXPECT_EQ(b.outer.size(), 2 * b.outer_ids.size());
}

TEST(Boundary, ClockwiseLoopPutsTheInsideOnTheRight) {
  auto segments = Square(2, 8, 1);
  const std::vector<Eigen::Vector2d> path = {{0, 0}, {0, 10}, {10, 10}, {10, 0}, {0, 0}};
  const auto b = perceptual_map::ComputeBoundary(segments, path, {});
  EXPECT_FALSE(b.inner_is_left);
  EXPECT_EQ(b.inner_ids.size(), 4u);
  EXPECT_TRUE(b.outer_ids.empty());
}

TEST(Boundary, GeometryHelpers) {
  EXPECT_TRUE(perceptual_map::SegmentsIntersect({0, 0}, {2, 2}, {0, 2}, {2, 0}));
  EXPECT_FALSE(perceptual_map::SegmentsIntersect({0, 0}, {1, 0}, {0, 1}, {1, 1}));
  EXPECT_TRUE(perceptual_map::SegmentsIntersect({0, 0}, {1, 0}, {1, 0}, {2, 5}));  // touching
  EXPECT_DOUBLE_EQ(perceptual_map::PointSegmentDistance({0, 1}, {-1, 0}, {1, 0}), 1.0);
  EXPECT_DOUBLE_EQ(perceptual_map::PointSegmentDistance({3, 0}, {-1, 0}, {1, 0}), 2.0);
  perceptual_map::BoundaryParams bad;
  bad.objects_per_side = 0;
  EXPECT_THROW(perceptual_map::ComputeBoundary({}, {}, bad), std::invalid_argument);
  // No path: no sides, everything outer, nothing removed.
  const auto b = perceptual_map::ComputeBoundary(Square(0, 1, 1), {}, {});
  EXPECT_EQ(b.outer_ids.size(), 4u);
}

}  // namespace
}  // namespace epmap
