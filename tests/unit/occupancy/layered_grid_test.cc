#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "perception/occupancy/layered_grid.h"

namespace epmap {
namespace {

using occupancy::LayeredGrid;

occupancy::MeasurementParams FuzzyUnion() {
  occupancy::MeasurementParams mp;
  mp.membership = occupancy::Membership::kFuzzyUnion;
  return mp;
}

// Default layers: [0.1, 0.7), [0.7, 1.3), [1.3, 2.0) above the floor; 10 cm cells.
TEST(LayeredGrid, RayFrequencyMarksEmptyCellsUpToThePointAndTheOccupiedCellAtIt) {
  LayeredGrid g;
  const occupancy::MeasurementParams mp;  // the default: Membership::kRayFrequency
  ASSERT_EQ(mp.membership, occupancy::Membership::kRayFrequency);
  ASSERT_TRUE(g.AddPoint({0.05, 0.05, 1.0}, {3.05, 0.05, 1.0}, 0.01, mp));
  const float prior = static_cast<float>(mp.frequency_prior);
  // One ray of weight 1: crossed cells mu_E = 1 / (1 + prior), the point's cell mu_O the same.
  for (int ix = 0; ix < 29; ++ix) {
    EXPECT_NEAR(g.At(1, ix, 0).empty, 1 / (1 + prior), 1e-6) << ix;
    EXPECT_EQ(g.At(1, ix, 0).occupied, 0.0F) << ix;
  }
  EXPECT_NEAR(g.At(1, 30, 0).occupied, 1 / (1 + prior), 1e-6);
  EXPECT_EQ(g.At(1, 30, 0).empty, 0.0F);
  EXPECT_EQ(g.At(1, 31, 0).confidence, 0.0F);
  // A second ray ending 1 m farther passes through the first point's cell: one hit, one pass.
  ASSERT_TRUE(g.AddPoint({0.05, 0.05, 1.0}, {4.05, 0.05, 1.0}, 0.01, mp));
  EXPECT_NEAR(g.At(1, 30, 0).occupied, 1 / (2 + prior), 1e-6);
  EXPECT_NEAR(g.At(1, 30, 0).empty, 1 / (2 + prior), 1e-6);
  EXPECT_NEAR(g.At(1, 5, 0).empty, 2 / (2 + prior), 1e-6);
}

// What the frequency model is for: stereo depth noise scatters a few of a wall's points into
// the cell in front of it. The union saturates that cell's mu_O; counted against the rays that
// pass through it to the wall, it stays free, and the wall stays one cell thick.
TEST(LayeredGrid, RayFrequencyKeepsTheCellInFrontOfAWallFreeWhereNoisyPointsLand) {
  const Eigen::Vector3d head(0.05, 0.05, 1.0);
  const auto build = [&](const occupancy::MeasurementParams& mp) {
    LayeredGrid g;
    for (int k = 0; k < 20; ++k) {
      // The wall's cell is 30 ([3.0, 3.1)); 4 of 20 points fall short into cell 29, 6 beyond
      // the face into the wall (cell 31), and their rays pass through cell 29 (a ray stops
      // giving empty evidence one cell before its point).
      const double x = k < 4 ? 2.95 : (k < 14 ? 3.05 : 3.15);
      g.AddPoint(head, {x, 0.05, 1.0}, 0.01, mp);
    }
    return g;
  };
  const LayeredGrid frequency = build({});
  const LayeredGrid fuzzy_union = build(FuzzyUnion());
  const auto occupied = [](const LayeredGrid& g, int ix) {
    const auto c = g.Combined(ix, 0);
    return c.occupied - c.empty >= 0.3F;  // occupancy >= 65: map_server's occupied_thresh
  };
  EXPECT_TRUE(occupied(fuzzy_union, 29));  // the union thickens the wall...
  EXPECT_FALSE(occupied(frequency, 29));   // ... the ray frequency does not
  EXPECT_LT(frequency.At(1, 29, 0).occupied, frequency.At(1, 29, 0).empty);
  EXPECT_TRUE(occupied(frequency, 30));
  EXPECT_TRUE(occupied(fuzzy_union, 30));
}

TEST(LayeredGrid, FuzzyUnionMarksEmptyCellsUpToThePointAndTheOccupiedCellAtIt) {
  LayeredGrid g;
  const occupancy::MeasurementParams mp = FuzzyUnion();
  ASSERT_TRUE(g.AddPoint({0.05, 0.05, 1.0}, {3.05, 0.05, 1.0}, 0.01, mp));
  // Camera height 1.0 m: layer 1. Cells between the head and the point are empty...
  for (int ix = 0; ix < 29; ++ix) {
    const auto c = g.At(1, ix, 0);
    EXPECT_NEAR(c.empty, mp.empty_evidence, 1e-6) << ix;
    EXPECT_EQ(c.occupied, 0.0F) << ix;
    EXPECT_GT(c.confidence, 0.0F);
  }
  // ... the point's cell is occupied, nothing beyond it is touched.
  EXPECT_NEAR(g.At(1, 30, 0).occupied, mp.occupied_evidence, 1e-6);
  EXPECT_EQ(g.At(1, 30, 0).empty, 0.0F);
  EXPECT_EQ(g.At(1, 31, 0).confidence, 0.0F);
  // Other layers and rows are untouched.
  EXPECT_EQ(g.At(0, 10, 0).confidence, 0.0F);
  EXPECT_EQ(g.At(2, 10, 0).confidence, 0.0F);
  EXPECT_EQ(g.At(1, 10, 1).confidence, 0.0F);
  // A second point on the same ray: the fuzzy union raises the memberships.
  g.AddPoint({0.05, 0.05, 1.0}, {3.05, 0.05, 1.0}, 0.01, mp);
  EXPECT_NEAR(g.At(1, 5, 0).empty, 1 - (1 - mp.empty_evidence) * (1 - mp.empty_evidence), 1e-6);
}

TEST(LayeredGrid, ARayToTheFloorCrossesLayersAndMarksNoObstacle) {
  LayeredGrid g;
  const occupancy::MeasurementParams mp;
  ASSERT_TRUE(g.AddPoint({0.05, 0.05, 1.0}, {2.05, 0.05, 0.0}, 0.01, mp));
  // Heights along the ray fall from 1.0 to 0: layer 1 near the head, layer 0 farther, then
  // the floor band (below 0.1 m), which is no layer.
  EXPECT_GT(g.At(1, 3, 0).empty, 0.0F);
  EXPECT_EQ(g.At(0, 3, 0).empty, 0.0F);
  EXPECT_GT(g.At(0, 12, 0).empty, 0.0F);
  EXPECT_EQ(g.At(1, 12, 0).empty, 0.0F);
  for (int l = 0; l < g.layer_count(); ++l) {
    for (int ix = 0; ix < 25; ++ix) EXPECT_EQ(g.At(l, ix, 0).occupied, 0.0F);
  }
}

TEST(LayeredGrid, VaguePointsCountLessAndFarOnesNotAtAll) {
  for (const occupancy::MeasurementParams& mp : {occupancy::MeasurementParams{}, FuzzyUnion()}) {
    LayeredGrid g;
    g.AddPoint({0.05, 0.05, 1.0}, {2.05, 0.05, 1.0}, 0.01, mp);
    g.AddPoint({0.05, 1.05, 1.0}, {2.05, 1.05, 1.0}, 0.4, mp);  // 4 cells of depth uncertainty
    EXPECT_GT(g.At(1, 20, 0).occupied, 1.9 * g.At(1, 20, 10).occupied);
    // Empty evidence stops one sigma (40 cm) before the vague point.
    EXPECT_GT(g.At(1, 15, 10).empty, 0.0F);
    EXPECT_EQ(g.At(1, 17, 10).empty, 0.0F);
  }
  // With the ray frequency, a sharp ray passing through outweighs a vague point's hit.
  LayeredGrid g;
  const occupancy::MeasurementParams mp;
  g.AddPoint({0.05, 0.05, 1.0}, {2.05, 0.05, 1.0}, 0.4, mp);
  g.AddPoint({0.05, 0.05, 1.0}, {4.05, 0.05, 1.0}, 0.01, mp);
  EXPECT_GT(g.At(1, 20, 0).empty, 3 * g.At(1, 20, 0).occupied);
  EXPECT_FALSE(g.AddPoint({0, 0, 1}, {mp.max_range_m + 1, 0, 1}, 0.01, mp));
  EXPECT_FALSE(g.AddPoint({0, 0, 1}, {std::nan(""), 0, 1}, 0.01, mp));
  EXPECT_FALSE(g.AddPoint({0, 0, 1}, {0, 0, 0.5}, 0.01, mp));  // straight down: no cell to mark
}

TEST(LayeredGrid, CombinedMapAndSyntheticMap) {
  LayeredGrid g;
  const occupancy::MeasurementParams mp;
  // A low obstacle (layer 0) at x = 2, seen over free space in layer 1.
  for (int k = 0; k < 5; ++k) g.AddPoint({0.05, 0.05, 0.4}, {2.05, 0.05, 0.4}, 0.01, mp);
  for (int k = 0; k < 5; ++k) g.AddPoint({0.05, 0.05, 1.0}, {4.05, 0.05, 1.0}, 0.01, mp);
  const auto c = g.Combined(20, 0);
  EXPECT_NEAR(c.occupied, g.At(0, 20, 0).occupied, 1e-6);
  EXPECT_LE(c.empty, 1.0F - c.occupied + 1e-6F);  // E = min(max_l E_l, 1 - O)
  EXPECT_GT(c.occupied, c.empty);
  const cv::Mat m = g.SyntheticMap();
  const int col = static_cast<int>(20 - g.min_ix()), row = static_cast<int>(0 - g.min_iy());
  // M = U_l (O_l n K_l).
  const float expect = std::max(std::min(g.At(0, 20, 0).occupied, g.At(0, 20, 0).confidence),
                                std::min(g.At(1, 20, 0).occupied, g.At(1, 20, 0).confidence));
  EXPECT_FLOAT_EQ(m.at<float>(row, col), expect);
  EXPECT_EQ(m.at<float>(row, static_cast<int>(10 - g.min_ix())), 0.0F);  // empty cell
}

// A table top at 0.75 m stops a tall robot, not one 0.5 m high: the export over the bands a
// robot can hit leaves out what stands above it, and over every band it is the combined map.
TEST(LayeredGrid, TheBandsARobotCanHitLeaveOutWhatIsAboveIt) {
  LayeredGrid g;
  const occupancy::MeasurementParams mp;
  for (int k = 0; k < 5; ++k) g.AddPoint({0.05, 0.05, 0.4}, {3.05, 0.05, 0.4}, 0.01, mp);
  for (int k = 0; k < 5; ++k) g.AddPoint({0.05, 0.05, 0.75}, {1.55, 0.05, 0.75}, 0.01, mp);
  EXPECT_EQ(g.LayersBelow(0.05), 0);  // not above the lowest band's floor: nothing to hit
  EXPECT_EQ(g.LayersBelow(0.5), 1);
  EXPECT_EQ(g.LayersBelow(0.7), 1);  // a band starting at the robot's top is out of reach
  EXPECT_EQ(g.LayersBelow(0.71), 2);
  EXPECT_EQ(g.LayersBelow(9.0), 3);
  EXPECT_EQ(g.LayersBelow(std::numeric_limits<double>::quiet_NaN()), 0);

  const auto at = [](const occupancy::GridExport& e, double x, double y) {
    const auto c = static_cast<uint32_t>(std::floor((x - e.origin_x) / e.resolution_m));
    const auto r = static_cast<uint32_t>(std::floor((y - e.origin_y) / e.resolution_m));
    return e.occupancy[r * e.width + c];
  };
  const auto low = g.ExportBelow(g.LayersBelow(0.5));
  const auto all = g.Export();
  EXPECT_TRUE(low.combined);
  EXPECT_EQ(low.combined_layers, 1u);
  EXPECT_EQ(all.combined_layers, 3u);
  EXPECT_GT(at(all, 1.55, 0.05), 65) << "the table top is an obstacle in the combined map";
  EXPECT_LT(at(low, 1.55, 0.05), 20) << "a low robot passes under it: free below 0.7 m";
  EXPECT_GT(at(low, 3.05, 0.05), 65) << "the low obstacle stays";
  const auto every = g.ExportBelow(g.layer_count());
  EXPECT_EQ(every.occupancy, all.occupancy);
  EXPECT_EQ(every.confidence, all.confidence);
  EXPECT_THROW(g.ExportBelow(0), std::out_of_range);
  EXPECT_THROW(g.ExportBelow(4), std::out_of_range);
}

TEST(LayeredGrid, AQueryForALayerThatDoesNotExistIsAClearErrorAndChangesNothing) {
  LayeredGrid g;
  g.AddPoint({0, 0, 1}, {2, 0, 1}, 0.01, {});
  const auto before = g.Export();
  try {
    g.Export(7);
    FAIL() << "expected std::out_of_range";
  } catch (const std::out_of_range& e) {
    EXPECT_NE(std::string(e.what()).find("layer 7"), std::string::npos) << e.what();
  }
  EXPECT_THROW(g.At(-1, 0, 0), std::out_of_range);
  EXPECT_EQ(g.Export().occupancy, before.occupancy);
  EXPECT_NO_THROW(g.Export(2));
}

TEST(LayeredGrid, GrowsAndKeepsWhatItHad) {
  LayeredGrid g(occupancy::GridParams{0.1, {0.10, 0.70, 1.30, 2.00}, 1.0});  // 1 m margin
  g.AddPoint({0.05, 0.05, 1.0}, {1.05, 0.05, 1.0}, 0.01, {});
  const auto cell = g.At(1, 10, 0);
  EXPECT_GT(g.origin().x(), -3.0);
  g.AddPoint({0.05, 0.05, 1.0}, {-3.05, 3.05, 1.0}, 0.01, {});
  EXPECT_FLOAT_EQ(g.At(1, 10, 0).occupied, cell.occupied);
  EXPECT_LE(g.origin().x(), -3.1);
  EXPECT_GT(g.At(1, -31, 30).occupied, 0.0F);
  // Copies are values: changing the original leaves the copy as it was.
  const LayeredGrid copy = g;
  g.AddPoint({0.05, 0.05, 1.0}, {1.05, 0.05, 1.0}, 0.01, {});
  EXPECT_FLOAT_EQ(copy.At(1, 10, 0).occupied, cell.occupied);
  EXPECT_GT(g.At(1, 10, 0).occupied, cell.occupied);
}

// A snapshot of an unchanged map costs no copy of its cells: copies share them until one of
// the grids changes, and then only that one gets its own (by a point, a merge, growth or a
// restore), whichever of the two it is.
TEST(LayeredGrid, CopiesShareTheCellsUntilOneChanges) {
  const occupancy::MeasurementParams mp;
  LayeredGrid g;
  g.AddPoint({0.05, 0.05, 1.0}, {1.05, 0.05, 1.0}, 0.01, mp);
  const auto cells_of = [](const LayeredGrid& grid) {
    return grid.planes()[1].occupied.ptr<float>();
  };
  const auto before = g.Export();
  LayeredGrid snapshot = g;
  EXPECT_EQ(cells_of(snapshot), cells_of(g));  // shared: no copy made
  // The original changes: the snapshot keeps the cells as they were.
  g.AddPoint({0.05, 0.05, 1.0}, {1.05, 0.35, 1.0}, 0.01, mp);
  EXPECT_NE(cells_of(snapshot), cells_of(g));
  EXPECT_EQ(snapshot.Export().occupancy, before.occupancy);
  EXPECT_NE(g.Export().occupancy, before.occupancy);
  // The copy changes (a merge, as an open stop's provisional map does): the original stays.
  const auto g_now = g.Export();
  LayeredGrid provisional = g;
  provisional.MergeWeighted(snapshot, 3, 0);
  EXPECT_EQ(g.Export().occupancy, g_now.occupancy);
  EXPECT_NE(provisional.Export().occupancy, g_now.occupancy);
  // Growth of a copy (a point far away) leaves the original's extent and cells.
  LayeredGrid grown = g;
  ASSERT_TRUE(grown.AddPoint({-4.0, 4.0, 1.0}, {-6.05, 6.05, 1.0}, 0.01, mp));
  EXPECT_NE(grown.width(), g.width());
  EXPECT_EQ(g.Export().occupancy, g_now.occupancy);
  // A restore into a copy: the original keeps its cells.
  LayeredGrid restored = g;
  restored.RestorePlanes(snapshot.min_ix(), snapshot.min_iy(), snapshot.width(), snapshot.height(),
                         snapshot.planes());
  EXPECT_EQ(restored.Export().occupancy, before.occupancy);
  EXPECT_EQ(g.Export().occupancy, g_now.occupancy);
  // ... and the planes it was given stay the snapshot's: changing the restored grid leaves them.
  EXPECT_NE(cells_of(restored), cells_of(snapshot));
  restored.AddPoint({0.05, 0.05, 1.0}, {1.05, 0.65, 1.0}, 0.01, mp);
  EXPECT_EQ(snapshot.Export().occupancy, before.occupancy);
  // A grid nobody shares changes in place.
  const float* own = cells_of(g);
  g.AddPoint({0.05, 0.05, 1.0}, {1.05, 0.15, 1.0}, 0.01, mp);
  EXPECT_EQ(cells_of(g), own);
}

// Walls seen from a few places: the map used as both the global map and, shifted, as the
// local one. Walls run through cell centres (5 cm off the lattice) so that rounding at cell
// boundaries cannot decide the answer.
LayeredGrid Room(Eigen::Vector2d offset) {
  offset += Eigen::Vector2d(0.05, 0.05);
  LayeredGrid g;
  const occupancy::MeasurementParams mp;
  const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> walls = {
      {{0, 0}, {6, 0}}, {{6, 0}, {6, 4}}, {{6, 4}, {2, 4}}, {{2, 4}, {2, 2.5}}};
  for (const Eigen::Vector2d& view : {Eigen::Vector2d(3, 2), Eigen::Vector2d(4.5, 1.5)}) {
    for (const auto& [a, b] : walls) {
      for (double t = 0; t <= 1; t += 0.01) {
        const Eigen::Vector2d p = a + t * (b - a) + offset;
        for (double z : {0.5, 1.0, 1.5}) {
          g.AddPoint({view.x() + offset.x(), view.y() + offset.y(), 1.0}, {p.x(), p.y(), z}, 0.02,
                     mp);
        }
      }
    }
  }
  return g;
}

TEST(Correlation, RecoversAKnownShift) {
  const LayeredGrid global = Room({0, 0});
  const LayeredGrid local = Room({0.3, -0.2});  // the robot thinks it is 30 cm / -20 cm off
  const auto reg = occupancy::CorrelateMaps(local, global, 0.6);
  EXPECT_EQ(reg.dx_cells, -3);
  EXPECT_EQ(reg.dy_cells, 2);
  EXPECT_NEAR(reg.dx_m, -0.3, 0.05);
  EXPECT_NEAR(reg.dy_m, 0.2, 0.05);
  EXPECT_GT(reg.score, 2 * reg.zero_score);
  EXPECT_GT(reg.local_cells, 50u);
  // Outside the search window the shift cannot be found (and nothing pretends it was).
  const auto narrow = occupancy::CorrelateMaps(local, global, 0.1);
  EXPECT_LE(std::abs(narrow.dx_cells), 1);
  LayeredGrid coarse(occupancy::GridParams{0.2, {0.1, 1.0}, 1.0});
  EXPECT_THROW(occupancy::CorrelateMaps(coarse, global, 0.5), std::invalid_argument);
}

TEST(Correlation, ACorridorFixesOnlyTheAxisAcrossIt) {
  // Two long parallel walls along x: the correlation peak is sharp across (y), flat along (x).
  const auto corridor = [](double dx) {
    LayeredGrid g;
    for (double x = 0.05; x < 12; x += 0.02) {
      for (double y : {-0.95, 1.05}) {
        g.AddPoint({6.05 + dx, 0.05, 1.0}, {x + dx, y, 1.0}, 0.02, occupancy::MeasurementParams{});
      }
    }
    return g;
  };
  const auto reg = occupancy::CorrelateMaps(corridor(0.2), corridor(0.0), 0.5);
  EXPECT_GT(reg.sharpness_y, 0.5);
  EXPECT_LT(reg.sharpness_x, 0.05);
  EXPECT_EQ(reg.dy_cells, 0);
}

TEST(Merge, WeightedAveragingByConfidence) {
  LayeredGrid global, local;
  const occupancy::MeasurementParams mp;
  global.AddPoint({0.05, 0.05, 1.0}, {2.05, 0.05, 1.0}, 0.01, mp);  // cell 20 occupied
  local.AddPoint({0.05, 0.05, 1.0}, {3.05, 0.05, 1.0}, 0.01, mp);   // cell 20 seen empty
  const auto g = global.At(1, 20, 0), l = local.At(1, 20, 0);
  LayeredGrid merged = global;
  merged.MergeWeighted(local);
  const auto m = merged.At(1, 20, 0);
  EXPECT_NEAR(
      m.occupied,
      (g.confidence * g.occupied + l.confidence * l.occupied) / (g.confidence + l.confidence),
      1e-6);
  EXPECT_NEAR(m.empty,
              (g.confidence * g.empty + l.confidence * l.empty) / (g.confidence + l.confidence),
              1e-6);
  EXPECT_NEAR(m.confidence, g.confidence + l.confidence - g.confidence * l.confidence, 1e-6);
  // Into an empty grid the local map arrives as it is, shifted as asked.
  LayeredGrid empty;
  empty.MergeWeighted(local, 2, -1);
  EXPECT_FLOAT_EQ(empty.At(1, 32, -1).occupied, local.At(1, 30, 0).occupied);
  LayeredGrid other_layers(occupancy::GridParams{0.1, {0.1, 1.0}, 1.0});
  EXPECT_THROW(other_layers.MergeWeighted(local), std::invalid_argument);
}

// occupied_depth_m: a point marks the cells behind it along its ray too (the body of the
// surface it lies on: a 12 cm wall seen from either side fills the same cells).
TEST(LayeredGrid, OccupiedDepthMarksTheBodyBehindAPoint) {
  occupancy::MeasurementParams mp;
  const float one_hit = static_cast<float>(1 / (1 + mp.frequency_prior));
  LayeredGrid surface_only;
  ASSERT_TRUE(surface_only.AddPoint({0.05, 0.05, 1.0}, {3.05, 0.05, 1.0}, 0.01, mp));
  EXPECT_NEAR(surface_only.At(1, 30, 0).occupied, one_hit, 1e-6);
  EXPECT_EQ(surface_only.At(1, 31, 0).confidence, 0.0F);

  mp.occupied_depth_m = 0.1;
  LayeredGrid with_body;
  ASSERT_TRUE(with_body.AddPoint({0.05, 0.05, 1.0}, {3.05, 0.05, 1.0}, 0.01, mp));
  EXPECT_NEAR(with_body.At(1, 30, 0).occupied, one_hit, 1e-6);
  EXPECT_NEAR(with_body.At(1, 31, 0).occupied, one_hit, 1e-6);
  EXPECT_EQ(with_body.At(1, 31, 0).empty, 0.0F);
  EXPECT_EQ(with_body.At(1, 32, 0).confidence, 0.0F);  // no farther than the depth
  EXPECT_EQ(with_body.At(0, 31, 0).confidence, 0.0F);  // at the point's height only
  // Along a diagonal ray the body follows the ray, not the axes.
  LayeredGrid diagonal;
  ASSERT_TRUE(diagonal.AddPoint({0.05, 0.05, 1.0}, {2.05, 2.05, 1.0}, 0.01, mp));
  EXPECT_GT(diagonal.At(1, 20, 20).occupied, 0.0F);
  EXPECT_GT(diagonal.At(1, 21, 21).occupied, 0.0F);
  EXPECT_EQ(diagonal.At(1, 20, 19).occupied, 0.0F);

  for (const double bad : {-0.1, std::numeric_limits<double>::quiet_NaN()}) {
    mp.occupied_depth_m = bad;
    EXPECT_THROW(mp.Validate(), std::invalid_argument) << bad;
  }
}

TEST(LayeredGrid, TheEmptyGapBeforeAPointHasAFloorInCells) {
  occupancy::MeasurementParams mp;
  // A precise point (sigma 1 cm) 5 cm into its cell: by default the ray stops clearing a whole
  // cell before it, so the cell in front (29) gets no pass ...
  LayeredGrid whole_cell;
  ASSERT_TRUE(whole_cell.AddPoint({0.05, 0.05, 1.0}, {3.05, 0.05, 1.0}, 0.01, mp));
  EXPECT_GT(whole_cell.At(1, 28, 0).empty, 0.0F);
  EXPECT_EQ(whole_cell.At(1, 29, 0).empty, 0.0F);
  // ... without the floor, one sigma before it: cell 29 is left 5 cm before the point.
  mp.empty_gap_min_cells = 0;
  LayeredGrid sigma_only;
  ASSERT_TRUE(sigma_only.AddPoint({0.05, 0.05, 1.0}, {3.05, 0.05, 1.0}, 0.01, mp));
  EXPECT_GT(sigma_only.At(1, 29, 0).empty, 0.0F);
  EXPECT_EQ(sigma_only.At(1, 30, 0).empty, 0.0F);  // never the point's own cell
  for (const double bad : {-0.5, std::numeric_limits<double>::quiet_NaN()}) {
    mp.empty_gap_min_cells = bad;
    EXPECT_THROW(mp.Validate(), std::invalid_argument) << bad;
  }
}

TEST(LayeredGrid, BadParametersAreRefused) {
  EXPECT_THROW(LayeredGrid(occupancy::GridParams{0.0, {0.1, 1.0}, 1.0}), std::invalid_argument);
  EXPECT_THROW(LayeredGrid(occupancy::GridParams{0.1, {1.0, 0.1}, 1.0}), std::invalid_argument);
  EXPECT_THROW(LayeredGrid(occupancy::GridParams{0.1, {0.1}, 1.0}), std::invalid_argument);
}

}  // namespace
}  // namespace epmap
