#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "perception/perceptual_map/reference_objects.h"

namespace epmap {
namespace {

TEST(ReferenceObjects, RegressionLineEndPointsFollowEquationsThreeAndFour) {
  // z = 0.5 x + 1 sampled on x in [1, 3] with small noise.
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0, 0.005);
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i <= 40; ++i) {
    const double x = 1 + i * 0.05;
    pts.emplace_back(x, 0.5 * x + 1 + n(rng));
  }
  perceptual_map::ReferenceObject o;
  ASSERT_TRUE(perceptual_map::FitLine(pts, &o));
  EXPECT_NEAR(o.a.x(), 1.0, 1e-12);  // x_p1 = min x
  EXPECT_NEAR(o.b.x(), 3.0, 1e-12);  // x_p2 = max x
  EXPECT_NEAR(o.a.y(), 1.5, 0.01);   // z_p1 = m x_p1 + b (Eq. 3)
  EXPECT_NEAR(o.b.y(), 2.5, 0.01);   // z_p2 = m x_p2 + b (Eq. 4)
  EXPECT_LT(o.rms_m, 0.01);

  // A line along the other axis (x constant) swaps the roles instead of failing.
  std::vector<Eigen::Vector2d> vertical;
  for (int i = 0; i <= 20; ++i) vertical.emplace_back(2.0, 0.1 * i);
  ASSERT_TRUE(perceptual_map::FitLine(vertical, &o));
  EXPECT_NEAR(o.a.x(), 2.0, 1e-12);
  EXPECT_NEAR(o.b.x(), 2.0, 1e-12);
  EXPECT_NEAR(o.length(), 2.0, 1e-12);

  EXPECT_FALSE(perceptual_map::FitLine({{1, 1}}, &o));
  EXPECT_FALSE(perceptual_map::FitLine({{1, 1}, {1, 1}}, &o));
}

TEST(ReferenceObjects, GridClusteringMakesOneLinePerCellAndDropsShortOnes) {
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < 100; ++i) pts.emplace_back(0.01 + 0.0198 * i, 1.2);  // 2 m wall at y=1.2
  for (int i = 0; i < 10; ++i) pts.emplace_back(3.201 + 0.003 * i, -1.0);  // 3 cm piece
  perceptual_map::ClusteringParams p;
  p.cell_size_m = 0.5;
  const auto objects = perceptual_map::FitReferenceObjects(pts, Eigen::Isometry2d::Identity(), p);
  // The wall crosses cells [0, 0.5), ..., [1.5, 2.0): four objects; the 3 cm piece is dropped.
  ASSERT_EQ(objects.size(), 4u);
  for (const auto& o : objects) {
    EXPECT_NEAR(o.a.y(), 1.2, 1e-9);
    EXPECT_NEAR(o.length(), 0.48, 0.03);
  }
  // With a grid turned by the view's pose, the cells move with the world, not with the robot.
  Eigen::Isometry2d T = Eigen::Isometry2d::Identity();
  T.translation() = Eigen::Vector2d(0.25, 0);
  EXPECT_EQ(perceptual_map::FitReferenceObjects(pts, T, p).size(), 5u);
}

TEST(ReferenceObjects, FarPointsAreGroupedInLargerCells) {
  // A 2 m wall across the line of sight 9.5 m ahead, its points scattered 0.3 m across it (the
  // depth noise of a far wall): in the 1 m cells used beyond 8 m, each cell holds the whole
  // scatter and fits a line along the wall; the 0.5 m cells near the robot still cut a wall
  // every half metre.
  std::mt19937 rng(3);
  std::normal_distribution<double> across(0, 0.3);
  std::vector<Eigen::Vector2d> far;
  for (int i = 0; i < 200; ++i) far.emplace_back(9.5 + across(rng), -0.995 + 0.01 * i);
  perceptual_map::ClusteringParams p;
  ASSERT_EQ(p.far_from_range_m, 8.0);
  ASSERT_EQ(p.far_cell_size_m, 1.0);
  auto objects = perceptual_map::FitReferenceObjects(far, Eigen::Isometry2d::Identity(), p);
  std::sort(objects.begin(), objects.end(),
            [](const auto& a, const auto& b) { return a.point_count > b.point_count; });
  ASSERT_GE(objects.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    const auto& o = objects[k];
    EXPECT_GT(o.point_count, 80);
    EXPECT_NEAR(o.mid().x(), 9.5, 0.15);
    EXPECT_GT(o.length(), 0.9);
    EXPECT_GT(std::abs((o.b - o.a).normalized().y()), std::cos(15.0 * M_PI / 180.0));
  }
  // Turned off: the 0.5 m cells split the scatter across the wall into slivers.
  p.far_from_range_m = 0;
  objects = perceptual_map::FitReferenceObjects(far, Eigen::Isometry2d::Identity(), p);
  for (const auto& o : objects) EXPECT_LT(o.point_count, 80);

  std::vector<Eigen::Vector2d> near;
  for (int i = 0; i < 100; ++i) near.emplace_back(3.2, -0.99 + 0.02 * i);
  EXPECT_EQ(perceptual_map::FitReferenceObjects(near, Eigen::Isometry2d::Identity(), {}).size(),
            4u);

  perceptual_map::ClusteringParams bad;
  bad.far_cell_size_m = 0;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
  bad = {};
  bad.far_from_range_m = -1;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

TEST(ReferenceObjects, FarLinesAlongTheLineOfSightAreDepthNoise) {
  // Points spread along the line of sight (as stereo depth noise spreads a far wall's points):
  // dropped beyond 4 m, kept near (where a line of sight along a wall is a real wall).
  std::vector<Eigen::Vector2d> far, near;
  for (int i = 0; i < 20; ++i) {
    far.emplace_back(6.05 + 0.02 * i, 1.05 + 0.003 * i);
    near.emplace_back(2.05 + 0.02 * i, 0.55 + 0.003 * i);
  }
  const auto id = Eigen::Isometry2d::Identity();
  EXPECT_TRUE(perceptual_map::FitReferenceObjects(far, id, {}).empty());
  EXPECT_EQ(perceptual_map::FitReferenceObjects(near, id, {}).size(), 1u);
  perceptual_map::ClusteringParams off;
  off.radial_max_angle_rad = 0;
  EXPECT_EQ(perceptual_map::FitReferenceObjects(far, id, off).size(), 1u);
}

TEST(ReferenceObjects, AFarCorridorWallAlongTheLineOfSightIsKept) {
  // A corridor's wall 6 m ahead runs within 20 degrees of the line of sight too (11 here), but
  // 1.25 m to the side of the robot: a line that does not pass through the view's origin is a
  // surface, not depth noise. With no offset allowed it is dropped, as before.
  std::vector<Eigen::Vector2d> wall;
  for (int i = 0; i < 20; ++i) wall.emplace_back(6.02 + 0.023 * i, 1.25 + (i % 2 ? 0.01 : -0.01));
  const auto id = Eigen::Isometry2d::Identity();
  const auto kept = perceptual_map::FitReferenceObjects(wall, id, {});
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_NEAR(kept[0].mid().y(), 1.25, 0.02);
  perceptual_map::ClusteringParams through_origin_only;
  through_origin_only.radial_min_offset_m = 1e9;
  EXPECT_TRUE(perceptual_map::FitReferenceObjects(wall, id, through_origin_only).empty());
}

TEST(ReferenceObjects, AFarWallMayScatterMoreThanANearOne) {
  // The same wall piece, its points 0.115 m from its line: beyond max_rms_m near the
  // robot, within it 7 m away, where stereo depth noise is larger (max_rms_growth_per_m2).
  auto piece = [](double x0) {
    std::vector<Eigen::Vector2d> pts;
    for (int i = 0; i < 20; ++i) pts.emplace_back(x0 + (i % 2 ? 0.115 : -0.115), 0.02 + 0.0237 * i);
    return pts;
  };
  const auto id = Eigen::Isometry2d::Identity();
  EXPECT_TRUE(perceptual_map::FitReferenceObjects(piece(1.25), id, {}).empty());
  EXPECT_EQ(perceptual_map::FitReferenceObjects(piece(7.25), id, {}).size(), 1u);
  perceptual_map::ClusteringParams fixed;
  fixed.max_rms_growth_per_m2 = 0;
  EXPECT_TRUE(perceptual_map::FitReferenceObjects(piece(7.25), id, fixed).empty());
  perceptual_map::ClusteringParams bad;
  bad.max_rms_growth_per_m2 = -1;
  EXPECT_THROW(perceptual_map::FitReferenceObjects(piece(7.25), id, bad), std::invalid_argument);
}

TEST(ReferenceObjects, CellsWithoutALineAreDropped) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 0.49);
  std::vector<Eigen::Vector2d> clutter;
  for (int i = 0; i < 50; ++i) clutter.emplace_back(u(rng), u(rng));
  EXPECT_TRUE(
      perceptual_map::FitReferenceObjects(clutter, Eigen::Isometry2d::Identity(), {}).empty());
  perceptual_map::ClusteringParams bad;
  bad.cell_size_m = 0;
  EXPECT_THROW(perceptual_map::FitReferenceObjects(clutter, Eigen::Isometry2d::Identity(), bad),
               std::invalid_argument);
}

}  // namespace
}  // namespace epmap
