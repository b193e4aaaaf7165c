#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "perception/mobile_mapping/map_evaluation.h"

namespace epmap {
namespace {

using mobile_mapping::Segment2;

TEST(MapEvaluation, CoveredShareOfWallLength) {
  const std::vector<Segment2> walls = {{{0, 0}, {10, 0}}, {{0, 5}, {10, 5}}};
  // A map that holds the first 6 m of the first wall, 30 cm off, and a stray piece.
  const std::vector<Segment2> map = {{{0, 0.3}, {6, 0.3}}, {{5, 2.5}, {7, 2.5}}};
  // Within 0.5 m of the piece: x in [0, 6 + sqrt(0.5^2 - 0.3^2)] = 6.4 m of 20 m.
  EXPECT_NEAR(mobile_mapping::CoveredShare(walls, map, 0.5), 6.4 / 20.0, 0.01);
  EXPECT_NEAR(mobile_mapping::CoveredShare(walls, map, 0.2), 0.0, 1e-9);
  // Map length farther than 1 m from any wall: the stray 2 m of 8 m.
  EXPECT_NEAR(1.0 - mobile_mapping::CoveredShare(map, walls, 1.0), 2.0 / 8.0, 0.01);
  EXPECT_EQ(mobile_mapping::CoveredShare({}, map, 0.5), 0.0);
  EXPECT_NEAR(mobile_mapping::TotalLength(walls), 20.0, 1e-12);
}

TEST(MapEvaluation, VisibleWallsOnly) {
  // The second wall hides behind the first from a viewpoint below both.
  const std::vector<Segment2> walls = {{{0, 1}, {10, 1}}, {{2, 3}, {8, 3}}};
  const std::vector<Segment2> map = {{{0, 1}, {10, 1}}};
  double visible = 0;
  const double share =
      mobile_mapping::CoveredVisibleShare(walls, map, 0.5, {{5, 0}}, 20.0, &visible);
  EXPECT_NEAR(visible, 10.0, 0.1);
  EXPECT_NEAR(share, 1.0, 1e-9);
  // Too far to see anything.
  mobile_mapping::CoveredVisibleShare(walls, map, 0.5, {{5, 0}}, 0.5, &visible);
  EXPECT_EQ(visible, 0.0);
}

TEST(MapEvaluation, AWallsHiddenFaceIsCoverableFromItsSeenOne) {
  // A 12 cm wall block seen from below: its far face (y = 1.12) is hidden, but lies within
  // 0.5 m of the seen face, so a map of what is seen can cover it; the wall at y = 3 it hides
  // cannot be covered by any map of the seen walls.
  const std::vector<Segment2> walls = {
      {{0, 1}, {10, 1}}, {{0, 1.12}, {10, 1.12}}, {{2, 3}, {8, 3}}};
  const auto parts = mobile_mapping::VisibleParts(walls, {{5, 0}}, 20.0);
  EXPECT_NEAR(mobile_mapping::TotalLength(parts), 10.0, 0.1);
  for (const auto& p : parts) EXPECT_NEAR(p.a.y(), 1.0, 1e-9);
  EXPECT_NEAR(mobile_mapping::CoveredShare(walls, parts, 0.5), 20.0 / 26.0, 0.01);
  EXPECT_TRUE(mobile_mapping::VisibleParts(walls, {{5, 0}}, 0.5).empty());
}

TEST(MapEvaluation, OnlyWhatACameraHadInItsFieldOfViewIsSeen) {
  // A room 10 m x 8 m; a camera in its middle, (5, 4), looking east (+x) with a 30 degree half
  // field of view sees the east wall within 5 tan(30 deg) = 2.89 m of its axis, none of the
  // others.
  const std::vector<Segment2> walls = {
      {{0, 0}, {10, 0}}, {{10, 0}, {10, 8}}, {{10, 8}, {0, 8}}, {{0, 8}, {0, 0}}};
  const double half_fov = 30.0 * M_PI / 180.0;
  const mobile_mapping::PlanarView east{{5, 4}, {1, 0}, half_fov};
  auto parts = mobile_mapping::VisibleSeenParts(walls, {east}, 20.0);
  EXPECT_NEAR(mobile_mapping::TotalLength(parts), 2 * 5 * std::tan(half_fov), 0.1);
  for (const auto& p : parts) EXPECT_NEAR(p.a.x(), 10.0, 1e-9);
  // Panned to the north-east (45 degrees, so 15 to 75 degrees in view): the north wall from
  // x = 5 + 4 / tan(75 deg) to its corner, the east wall from y = 4 + 5 tan(15 deg) up.
  const double deg = M_PI / 180.0;
  const double north = 10 - (5 + 4 / std::tan(75 * deg));
  const double east_top = 8 - (4 + 5 * std::tan(15 * deg));
  const mobile_mapping::PlanarView north_east{{5, 4}, Eigen::Vector2d(1, 1).normalized(), half_fov};
  parts = mobile_mapping::VisibleSeenParts(walls, {north_east}, 20.0);
  EXPECT_NEAR(mobile_mapping::TotalLength(parts), north + east_top, 0.1);
  // Both views: their union; the same pose twice counts once.
  const double east_union = 8 - (4 - 5 * std::tan(half_fov));
  parts = mobile_mapping::VisibleSeenParts(walls, {east, north_east, north_east}, 20.0);
  EXPECT_NEAR(mobile_mapping::TotalLength(parts), east_union + north, 0.1);
  // A view without an axis looks all around, as VisibleParts does.
  parts = mobile_mapping::VisibleSeenParts(walls, {{{5, 4}, Eigen::Vector2d::Zero(), 0}}, 20.0);
  EXPECT_NEAR(mobile_mapping::TotalLength(parts), 36.0, 0.1);
  // Out of range, or no views: nothing seen.
  EXPECT_TRUE(mobile_mapping::VisibleSeenParts(walls, {east}, 4.0).empty());
  EXPECT_TRUE(mobile_mapping::VisibleSeenParts(walls, {}, 20.0).empty());
}

TEST(MapEvaluation, GridIouAgainstRasterisedWalls) {
  occupancy::GridExport g;
  g.resolution_m = 0.1;
  g.origin_x = 0;
  g.origin_y = 0;
  g.width = 20;
  g.height = 10;
  g.occupancy.assign(200, 0);
  g.confidence.assign(200, 200);
  // A wall along y = 0.55 (through cell centres of row 5) from x = 0.05 to 1.05: 11 cells.
  const std::vector<Segment2> walls = {{{0.05, 0.55}, {1.05, 0.55}}};
  for (int c = 0; c <= 10; ++c) g.occupancy[5 * 20 + c] = 100;
  auto s = mobile_mapping::ScoreGrid(g, walls);
  EXPECT_EQ(s.wall_cells, 11u);
  EXPECT_EQ(s.occupied, 11u);
  EXPECT_DOUBLE_EQ(s.iou, 1.0);
  // Half the wall missed, two stray cells, a row of the wall unknown.
  for (int c = 6; c <= 10; ++c) g.occupancy[5 * 20 + c] = 0;
  g.occupancy[0] = g.occupancy[1] = 90;
  s = mobile_mapping::ScoreGrid(g, walls);
  EXPECT_EQ(s.intersection, 6u);
  EXPECT_NEAR(s.iou, 6.0 / (8 + 5), 1e-12);
  for (int c = 8; c <= 10; ++c) g.occupancy[5 * 20 + c] = occupancy::GridExport::kUnknown;
  s = mobile_mapping::ScoreGrid(g, walls);
  EXPECT_EQ(s.wall_cells_observed, 8u);
  EXPECT_NEAR(s.iou_observed, 6.0 / (8 + 2), 1e-12);
  EXPECT_NEAR(s.precision, 6.0 / 8, 1e-12);        // 6 of the 8 occupied cells on the wall
  EXPECT_NEAR(s.recall_observed, 6.0 / 8, 1e-12);  // 6 of the 8 known wall cells occupied
  // A wall exactly on a cell boundary touches the cells on both sides.
  EXPECT_EQ(mobile_mapping::ScoreGrid(g, {{{0.05, 0.5}, {0.15, 0.5}}}).wall_cells, 4u);
}

TEST(MapEvaluation, RasterisedSolidsIncludeTheirBody) {
  occupancy::GridExport g;
  g.resolution_m = 0.1;
  g.width = 10;
  g.height = 10;
  g.occupancy.assign(100, 0);
  g.confidence.assign(100, 200);
  // A 12 cm wall along y, faces at x = 0.39 and 0.51, from y = 0.25 to 0.75 as a closed outline
  // (as walls.csv lists it): column 4 ([0.4, 0.5)) touches neither face but is inside.
  const std::vector<Segment2> slab = {{{0.39, 0.25}, {0.39, 0.75}},
                                      {{0.39, 0.75}, {0.51, 0.75}},
                                      {{0.51, 0.75}, {0.51, 0.25}},
                                      {{0.51, 0.25}, {0.39, 0.25}}};
  const auto cells = mobile_mapping::RasteriseWalls(g, slab);
  for (int r = 2; r <= 7; ++r) {
    EXPECT_EQ(cells[static_cast<size_t>(r * 10 + 3)], 1) << "face cell, row " << r;
    EXPECT_EQ(cells[static_cast<size_t>(r * 10 + 4)], 1) << "body cell, row " << r;
    EXPECT_EQ(cells[static_cast<size_t>(r * 10 + 5)], 1) << "face cell, row " << r;
  }
  EXPECT_EQ(cells[static_cast<size_t>(5 * 10 + 2)], 0);
  EXPECT_EQ(cells[static_cast<size_t>(5 * 10 + 6)], 0);
  EXPECT_EQ(std::count(cells.begin(), cells.end(), 1), 3 * 6);
  // The same segments out of order are no outline: only the faces.
  const std::vector<Segment2> open = {slab[0], slab[2], slab[1], slab[3]};
  const auto faces = mobile_mapping::RasteriseWalls(g, open);
  EXPECT_EQ(faces[static_cast<size_t>(5 * 10 + 4)], 0);
  // A 1 m x 0.6 m footprint (a desk): all 10 x 6 cells inside, plus the cells its edges touch.
  const std::vector<Segment2> desk = {{{0.0, 0.0}, {1.0, 0.0}},
                                      {{1.0, 0.0}, {1.0, 0.6}},
                                      {{1.0, 0.6}, {0.0, 0.6}},
                                      {{0.0, 0.6}, {0.0, 0.0}}};
  const auto d = mobile_mapping::RasteriseWalls(g, desk);
  EXPECT_EQ(std::count(d.begin(), d.end(), 1), 10 * 7);  // rows 0-6 (y = 0.6 touches row 6)
}

}  // namespace
}  // namespace epmap
