// What epmapd publishes for ROS 2 (services/mapping/ros_output): the grid in
// nav_msgs/OccupancyGrid's layout and the map -> odom transform.

#include "services/mapping/ros_output/ros_map_publisher.h"

#include <epmap_dds/OccupancyGrid.h>
#include <gtest/gtest.h>

#include <numbers>

namespace epmap::mapping {
namespace {

Eigen::Isometry2d Pose(double x, double y, double theta) {
  return Eigen::Translation2d(x, y) * Eigen::Rotation2Dd(theta);
}

TEST(RosMapPublisher, TheGridKeepsItsLayoutAndUnknownBecomesMinusOne) {
  occupancy::GridExport g;
  g.resolution_m = 0.1;
  g.origin_x = -1.5;
  g.origin_y = 2.25;
  g.width = 3;
  g.height = 2;
  // Row-major from the lowest y row in both layouts.
  g.occupancy = {0, 100, occupancy::GridExport::kUnknown, 50, 65, 12};
  nav_msgs::msg::OccupancyGrid msg;
  ToRosGrid(g, -1'500'000'000, "map", &msg);  // a stamp before 1970 too
  EXPECT_EQ(msg.header().frame_id(), "map");
  EXPECT_EQ(msg.header().stamp().sec(), -2);
  EXPECT_EQ(msg.header().stamp().nanosec(), 500'000'000u);
  EXPECT_FLOAT_EQ(msg.info().resolution(), 0.1F);
  EXPECT_EQ(msg.info().width(), 3u);
  EXPECT_EQ(msg.info().height(), 2u);
  EXPECT_DOUBLE_EQ(msg.info().origin().position().x(), -1.5);
  EXPECT_DOUBLE_EQ(msg.info().origin().position().y(), 2.25);
  EXPECT_DOUBLE_EQ(msg.info().origin().orientation().w(), 1.0);
  const std::vector<int8_t> want = {0, 100, -1, 50, 65, 12};
  EXPECT_EQ(msg.data(), want);
}

TEST(RosMapPublisher, MapToOdomCarriesTheOdometryPoseOntoTheCorrectedOne) {
  const Eigen::Isometry2d odometry = Pose(4.0, -1.0, 0.3);
  const Eigen::Isometry2d corrected = Pose(3.6, -0.7, 0.25);
  const Eigen::Isometry2d T_map_odom = MapToOdom(corrected, odometry);
  // tf chains map -> odom -> base: that must give the corrected pose.
  EXPECT_TRUE((T_map_odom * odometry).isApprox(corrected, 1e-12));
  // No correction: identity.
  EXPECT_TRUE(MapToOdom(odometry, odometry).isApprox(Eigen::Isometry2d::Identity(), 1e-12));
}

}  // namespace
}  // namespace epmap::mapping
