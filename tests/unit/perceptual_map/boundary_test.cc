#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

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

void ExpectSameBoundary(const perceptual_map::Boundary& a, const perceptual_map::Boundary& b,
                        const std::string& what) {
  EXPECT_EQ(a.removed_on_path, b.removed_on_path) << what;
  EXPECT_EQ(a.inner_ids, b.inner_ids) << what;
  EXPECT_EQ(a.outer_ids, b.outer_ids) << what;
  EXPECT_EQ(a.inner, b.inner) << what;
  EXPECT_EQ(a.outer, b.outer) << what;
  EXPECT_EQ(a.inner_is_left, b.inner_is_left) << what;
}

// The cell grids only choose what to compare: every cell size gives the boundary of comparing
// everything with everything (index_cell_m = 0), on wandering paths that cross and revisit
// themselves, on a lattice where many distances tie, with objects that are not finite and
// with one a million kilometres long (kept out of the cells: memory stays bounded).
TEST(Boundary, TheIndexGivesTheSameBoundaryAsComparingEverything) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 24; ++trial) {
    const bool lattice = trial % 4 == 3;  // whole-metre coordinates: ties everywhere
    const auto coord = [&](double scale) {
      const double v = u(rng) * scale;
      return lattice ? std::round(v) : v;
    };
    std::vector<Eigen::Vector2d> path = {{0, 0}};
    for (int i = 0; i < 60; ++i) path.push_back(path.back() + Eigen::Vector2d(coord(3), coord(3)));
    if (trial % 5 == 0) path.push_back(path[3]);  // repeated points and a revisit
    std::vector<MapSegment> segments;
    for (uint32_t id = 1; id <= 150; ++id) {
      const Eigen::Vector2d a = path[rng() % path.size()] + Eigen::Vector2d(coord(8), coord(8));
      segments.push_back({id, a, a + Eigen::Vector2d(coord(2), coord(2)), 1, 1});
    }
    if (trial % 10 == 9) segments[5].b.x() = std::numeric_limits<double>::quiet_NaN();
    if (trial % 10 == 8) {  // far from the path (so not removed as crossing it), and wild
      segments[6].a = {1e6, 1e6};
      segments[6].b = {1e6 + 1e9, 1e6 + 3e8};
    }
    perceptual_map::BoundaryParams everything;
    everything.index_cell_m = 0;
    const auto reference = perceptual_map::ComputeBoundary(segments, path, everything);
    ASSERT_GT(reference.inner_ids.size() + reference.outer_ids.size(), 10u);
    for (const double cell : {0.3, 2.0, 7.0}) {
      perceptual_map::BoundaryParams p;
      p.index_cell_m = cell;
      ExpectSameBoundary(perceptual_map::ComputeBoundary(segments, path, p), reference,
                         "trial " + std::to_string(trial) + ", cell " + std::to_string(cell));
    }
  }
  perceptual_map::BoundaryParams bad;
  bad.index_cell_m = -1;
  EXPECT_THROW(perceptual_map::ComputeBoundary({}, {}, bad), std::invalid_argument);
}

}  // namespace
}  // namespace epmap
