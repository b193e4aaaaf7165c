#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "clients/sim/record.h"
#include "clients/sim/scenario.h"
#include "common/dataset/dataset.h"
#include "perception/kinematics/urdf_chain.h"
#include "perception/perceptual_map/boundary.h"
#include "tests/support/test_env.h"
#include "tests/unit/sim/warp_check.h"

namespace epmap::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

ScenarioOptions Building(bool noise = true, bool reverse = false,
                         const std::string& route = "corridors") {
  ScenarioOptions o;
  o.name = "building";
  o.noise = noise;
  o.reverse = reverse;
  o.route = route;
  return o;
}

Eigen::Isometry3d Planar(const dataset::PlanarPose& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(p.x, p.y, 0);
  T.linear() = Eigen::AngleAxisd(p.theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

TEST(BuildingScenario, RightImageWarpedByTrueDisparityReproducesLeft) {
  const Scenario* s = &testing::Shared(Building());
  EXPECT_TRUE(s->rectified());
  const auto cam = s->cam0();
  EXPECT_EQ(cam.width, 320);
  EXPECT_NEAR(cam.fu, 251.48735, 1e-9);
  for (int index : {2, 150, 900}) {
    const SimFrame f = s->Render(index);
    ASSERT_EQ(f.left.type(), CV_8UC1);
    EXPECT_NEAR(f.gt_T_cam0_cam1.translation().x(), 0.12, 1e-12);
    const auto stats = testing::WarpRightIntoLeft(f, cam, 10.0);
    EXPECT_GT(stats.visible, 0.6 * f.left.total()) << "frame " << index;
    EXPECT_GE(stats.consistent_share(), 0.95) << "frame " << index;
  }
}

TEST(BuildingScenario, UrdfThroughKdlGivesTheRenderedCameraPoses) {
  const Scenario* s = &testing::Shared(Building(false));
  auto chain = kinematics::UrdfChain::FromString(s->urdf());
  EXPECT_EQ(s->joint_names(), std::vector<std::string>{"pan"});
  for (int index : {1, 400, 1200}) {
    const SimFrame f = s->Render(index);
    EXPECT_EQ(f.joints, f.gt_joints);
    const Eigen::Isometry3d T = Planar(*f.gt_base) * chain.Cam0Pose(f.joints);
    EXPECT_LT((T.matrix() - f.gt_T_world_cam0.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    // Exact odometry without noise: the forward run's start is the world frame.
    EXPECT_NEAR(f.odometry->x, f.gt_base->x, 1e-9);
    EXPECT_NEAR(f.odometry->y, f.gt_base->y, 1e-9);
    EXPECT_NEAR(std::remainder(f.odometry->theta - f.gt_base->theta, 2 * std::numbers::pi), 0,
                1e-9);
  }
}

class BuildingRoutes : public ::testing::TestWithParam<std::string> {};

TEST_P(BuildingRoutes, RouteStopsToLookAroundAndOdometryDrifts) {
  ScenarioOptions o = Building(true, false, GetParam());
  o.width = 32;  // geometry only: tiny images
  o.height = 24;
  const Scenario* s = &testing::Shared(o);
  EXPECT_GT(s->frame_count(), 1000);
  EXPECT_LT(s->frame_count(), 3000);
  EXPECT_DOUBLE_EQ(s->rate_hz(), 10.0);
  double length = 0, max_step = 0;
  int stops = 0;
  dataset::PlanarPose previous = *s->Render(0).gt_base;
  SimFrame last;
  for (int i = 0; i < s->frame_count(); ++i) {
    last = s->Render(i);
    const double step = std::hypot(last.gt_base->x - previous.x, last.gt_base->y - previous.y);
    length += step;
    max_step = std::max(max_step, step);
    if (last.at_stop) {
      ++stops;
      EXPECT_EQ(step, 0.0);
      EXPECT_LE(std::abs(last.gt_joints[0]), 60 * kDeg + 1e-9);
    } else {
      EXPECT_EQ(last.gt_joints[0], 0.0);
    }
    previous = *last.gt_base;
  }
  EXPECT_NEAR(length, 60.0, 2.0);
  EXPECT_LE(max_step, 0.05 + 1e-9);
  EXPECT_GT(stops / 7, 60);  // every metre or 45 degrees, 7 views each
  // Heading error of the dead reckoning at the end: of the order of 20 degrees (paper 002).
  const double heading_error =
      std::abs(std::remainder(last.odometry->theta - last.gt_base->theta, 2 * std::numbers::pi));
  EXPECT_GT(heading_error, 10 * kDeg);
  EXPECT_LT(heading_error, 30 * kDeg);
  const double position_error =
      std::hypot(last.odometry->x - last.gt_base->x, last.odometry->y - last.gt_base->y);
  EXPECT_GT(position_error, 0.5);
}

// --odometry-scale-error: the encoders count wheels (1 + E_s) larger than they are, so the
// dead-reckoned path is that much shorter than the true one (exact otherwise: no noise).
TEST(BuildingScenario, OdometryScaleErrorShortensTheCountedPath) {
  ScenarioOptions o = Building(false);
  o.width = 32;
  o.height = 24;
  o.frames = 400;
  o.odometry_scale_error = 0.01;
  const auto s = MakeScenario(o);
  double true_length = 0, counted_length = 0;
  SimFrame previous = s->Render(0);
  for (int i = 1; i < s->frame_count(); ++i) {
    const SimFrame f = s->Render(i);
    true_length +=
        std::hypot(f.gt_base->x - previous.gt_base->x, f.gt_base->y - previous.gt_base->y);
    counted_length +=
        std::hypot(f.odometry->x - previous.odometry->x, f.odometry->y - previous.odometry->y);
    previous = f;
  }
  ASSERT_GT(true_length, 5.0);
  EXPECT_NEAR(counted_length * 1.01, true_length, 1e-6);
}

// The robot (a 0.25 m radius around its centre) never drives through a wall, a door frame or
// the furniture: each route passes its doors clear of what stands near them.
TEST_P(BuildingRoutes, TheRobotKeepsClearOfWallsAndFurniture) {
  ScenarioOptions o = Building(true, false, GetParam());
  o.width = 32;
  o.height = 24;
  const Scenario* s = &testing::Shared(o);
  std::vector<dataset::WallSegment> obstacles = s->Walls();
  for (const auto& f : s->Furniture()) obstacles.push_back(f);
  double closest = 1e9;
  for (int i = 0; i < s->frame_count(); ++i) {
    const auto base = *s->Render(i).gt_base;
    for (const auto& w : obstacles) {
      closest = std::min(closest, perceptual_map::PointSegmentDistance({base.x, base.y},
                                                                       {w.x1, w.y1}, {w.x2, w.y2}));
    }
  }
  EXPECT_GT(closest, 0.25);
}

TEST_P(BuildingRoutes, ReverseStartsWhereTheForwardRunEnds) {
  ScenarioOptions o = Building(true, false, GetParam());
  o.width = 32;
  o.height = 24;
  const Scenario* forward = &testing::Shared(o);
  o.reverse = true;
  const Scenario* backward = &testing::Shared(o);
  const auto end = *forward->Render(forward->frame_count() - 1).gt_base;
  const auto start = *backward->Render(0).gt_base;
  EXPECT_NEAR(start.x, end.x, 1e-9);
  EXPECT_NEAR(start.y, end.y, 1e-9);
  EXPECT_NEAR(std::abs(std::remainder(start.theta - end.theta, 2 * std::numbers::pi)),
              std::numbers::pi, 1e-9);
  const auto back_end = *backward->Render(backward->frame_count() - 1).gt_base;
  EXPECT_NEAR(back_end.x, 0.0, 1e-9);  // it ends where the forward run started
  EXPECT_NEAR(back_end.y, 0.0, 1e-9);
  // Its odometry starts at zero in its own start frame.
  const auto odom0 = *backward->Render(0).odometry;
  EXPECT_EQ(odom0.x, 0.0);
  EXPECT_EQ(odom0.theta, 0.0);
}

// A long run: the route there and back twice. The second pass is the reverse run (it turns
// back where the first ended), the third the forward one again, and the odometry runs on.
TEST_P(BuildingRoutes, PassesDriveTheRouteThereAndBack) {
  ScenarioOptions o = Building(true, false, GetParam());
  o.width = 32;
  o.height = 24;
  const Scenario* one = &testing::Shared(o);
  o.passes = 3;
  const Scenario* three = &testing::Shared(o);
  const int n = one->frame_count();
  // Each turn back adds a half turn on the spot (40 frames, 4 look-arounds) and takes away
  // the look-around a single run starts with.
  EXPECT_GT(three->frame_count(), 3 * n);
  EXPECT_LT(three->frame_count(), 3 * n + 2 * 80);
  const auto end_of_one = *one->Render(n - 1).gt_base;
  const auto turned_back = *three->Render(n - 1).gt_base;  // where the first pass ends
  EXPECT_NEAR(turned_back.x, end_of_one.x, 1e-9);
  EXPECT_NEAR(turned_back.y, end_of_one.y, 1e-9);
  const auto end = *three->Render(three->frame_count() - 1).gt_base;
  EXPECT_NEAR(end.x, end_of_one.x, 1e-9);  // three passes end where one does
  EXPECT_NEAR(end.y, end_of_one.y, 1e-9);
  // Somewhere in the middle it is back at the start.
  double nearest_start = 1e9;
  for (int i = 2 * n - 100; i < 2 * n + 160 && i < three->frame_count(); ++i) {
    const auto p = *three->Render(i).gt_base;
    nearest_start = std::min(nearest_start, std::hypot(p.x, p.y));
  }
  EXPECT_LT(nearest_start, 1e-6);
  EXPECT_NE(three->Describe().find("3 passes"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(BuildingScenario, BuildingRoutes, ::testing::Values("corridors", "rooms"));

TEST(BuildingScenario, FloorPlanAndDisparityRange) {
  const Scenario* s = &testing::Shared(Building());
  const auto walls = s->Walls();
  ASSERT_GT(walls.size(), 50u);
  double min_x = 1e9, max_x = -1e9, min_y = 1e9, max_y = -1e9;
  for (const auto& w : walls) {
    for (const auto& [x, y] : {std::pair(w.x1, w.y1), std::pair(w.x2, w.y2)}) {
      min_x = std::min(min_x, x);
      max_x = std::max(max_x, x);
      min_y = std::min(min_y, y);
      max_y = std::max(max_y, y);
    }
  }
  // World frame = start pose, facing north: the 28 m (east-west) side spans world y.
  EXPECT_NEAR(max_x - min_x, 28.5 + 0.24, 0.01);
  EXPECT_NEAR(max_y - min_y, 28.0 + 0.24, 0.01);
  EXPECT_FALSE(s->Furniture().empty());
  // The disparity range covers the scene but for a jamb seen at ~0.35 m from two doorway stops.
  size_t known = 0, beyond = 0;
  for (int i = 0; i < s->frame_count(); i += 23) {
    const cv::Mat d = s->Render(i).gt_disparity;
    known += static_cast<size_t>(cv::countNonZero(d > 0));
    beyond += static_cast<size_t>(cv::countNonZero(d >= s->num_disparities()));
  }
  EXPECT_GT(known, 0u);
  EXPECT_LT(double(beyond) / known, 1e-3);
}

TEST(BuildingScenario, RecordWritesOdometryMapAndDisparityAtStops) {
  const auto dir = epmap::testing::FreshTempDir("sim-building");
  ScenarioOptions o = Building();
  o.frames = 20;
  o.width = 160;
  o.height = 120;
  const Scenario* s = &testing::Shared(o);
  Record(*s, dir / "b", false);
  const auto d = dataset::Load(dir / "b");
  EXPECT_EQ(d.frames.size(), 20u);
  EXPECT_TRUE(d.rectified());
  EXPECT_NEAR(d.baseline_m(), 0.12, 1e-9);
  EXPECT_EQ(d.odometry.size(), 20u);
  EXPECT_EQ(d.gt_base_pose.size(), 20u);
  EXPECT_EQ(d.gt_disparity.size(), 7u);  // the first look-around only
  EXPECT_EQ(d.walls.size(), s->Walls().size());
  EXPECT_TRUE(std::filesystem::exists(dir / "b/mav0/gt_map/furniture.csv"));
  EXPECT_EQ(d.joint_names, std::vector<std::string>{"pan"});
  std::filesystem::remove_all(dir);
}

// The walker (building_world.h): it changes the images only where the true mask says something
// moves on its own, its recorded centre lies on it, and the dataset carries both.
TEST(BuildingScenario, AWalkerMovesOnItsOwnWithItsTrueMaskAndPosition) {
  ScenarioOptions o = Building();
  o.first_frame = 300;  // driving along the corridor, the walker ahead in full view
  o.frames = 4;
  o.width = 160;
  o.height = 120;
  const Scenario* plain = &testing::Shared(o);
  o.walker = true;
  const Scenario* walking = &testing::Shared(o);
  EXPECT_FALSE(plain->has_moving_objects());
  ASSERT_TRUE(walking->has_moving_objects());
  const auto cam = walking->cam0();
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (int i = 0; i < o.frames; ++i) {
    const SimFrame with = walking->Render(i);
    const SimFrame without = plain->Render(i);
    EXPECT_TRUE(without.gt_mover_centres.empty());
    ASSERT_EQ(with.gt_mover_centres.size(), 1u);
    ASSERT_EQ(with.gt_unexpected.size(), with.left.size());
    const int seen = cv::countNonZero(with.gt_unexpected);
    EXPECT_GT(seen, 100) << "frame " << i;
    // Same world, same noise: the images differ only on the walker (and the blur's 1 px
    // around it).
    cv::Mat around;
    cv::dilate(with.gt_unexpected, around, cv::Mat::ones(5, 5, CV_8U));
    const cv::Mat changed = with.left != without.left;
    EXPECT_GT(cv::countNonZero(changed & around), seen / 2) << "frame " << i;
    EXPECT_EQ(cv::countNonZero(changed & ~around), 0) << "frame " << i;
    // The centre projects inside the mask's box.
    const Eigen::Vector3d c = with.gt_T_world_cam0.inverse() * with.gt_mover_centres[0];
    ASSERT_GT(c.z(), 0.5);
    const cv::Point2d px(cam.fu * c.x() / c.z() + cam.cu, cam.fv * c.y() / c.z() + cam.cv);
    EXPECT_TRUE(cv::Rect2d(cv::boundingRect(with.gt_unexpected)).contains(px)) << px;
    // Walking at 1.1 m/s: 11 cm a frame.
    if (i > 0) {
      EXPECT_NEAR((with.gt_mover_centres[0] - previous).norm(), 0.11, 0.03);
    }
    previous = with.gt_mover_centres[0];
  }
  // The run starts part-way along the route, with its odometry there.
  EXPECT_EQ(walking->Render(0).odometry->x, 0.0);
  EXPECT_GT(std::hypot(walking->Render(0).gt_base->x, walking->Render(0).gt_base->y), 5.0);

  const auto dir = epmap::testing::FreshTempDir("sim-walker");
  Record(*walking, dir / "w", false);
  const auto d = dataset::Load(dir / "w");
  EXPECT_EQ(d.gt_unexpected.size(), 4u);
  ASSERT_EQ(d.gt_movers.size(), 4u);
  EXPECT_EQ(d.gt_movers[2].stamp_ns, d.frames[2].stamp_ns);
  EXPECT_EQ(d.gt_movers[2].id, 1);
  EXPECT_LT((d.gt_movers[2].centre - walking->Render(2).gt_mover_centres[0]).norm(), 1e-6);
  std::filesystem::remove_all(dir);
}

TEST(BuildingScenario, TooManyFramesIsAClearError) {
  ScenarioOptions o = Building();
  o.frames = 100000;
  try {
    MakeScenario(o);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("route has"), std::string::npos);
  }
}

}  // namespace
}  // namespace epmap::sim
