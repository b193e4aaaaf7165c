// What epmapd publishes for ROS 2 (services/mapping/ros_output): the grid in
// nav_msgs/OccupancyGrid's layout and the map -> odom transform.

#include "services/mapping/ros_output/ros_map_publisher.h"

#include <epmap_dds/OccupancyGrid.h>
#include <epmap_dds/OccupancyGridPubSubTypes.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <numbers>
#include <thread>

#include "common/dds/endpoints.h"
#include "tests/support/test_env.h"
#include "tests/support/wait_for.h"

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

// A reader on rt/map, transient local as RViz's map display: how many writers it matched and
// how many grids it got.
struct MapListener {
  MapListener(dds::Participant& participant, const std::string& topic)
      : reader(
            participant, dds::RosTopic(topic), [this](nav_msgs::msg::OccupancyGrid&&) { ++grids; },
            1u << 20, 1, dds::Durability::kTransientLocal) {}
  std::atomic<int> grids{0};
  dds::Reader<nav_msgs::msg::OccupancyGrid, nav_msgs::msg::OccupancyGridPubSubType> reader;
};

using testing::WaitFor;

// One processed frame whose snapshot carries maps with one known grid cell.
std::shared_ptr<const MapSnapshot> FrameWithMaps(uint64_t frame_index) {
  auto maps = std::make_shared<mobile_mapping::MapsSnapshot>();
  maps->stamp_ns = 1'000'000'000;
  maps->grid.AddPoint({0, 0, 0.5}, {1.0, 0.2, 0.5}, 0.02, occupancy::MeasurementParams{});
  auto frame = std::make_shared<MapSnapshot>();
  frame->frame_index = frame_index;
  frame->stamp_ns = maps->stamp_ns;
  frame->maps = std::move(maps);
  return frame;
}

// A head announces no rt/map writer that would never publish; a mobile base creates it with
// its first maps, and a reader that was already waiting then gets the grid.
TEST(RosMapPublisher, TheWritersAppearWithTheFirstMapsOnly) {
  dds::Participant participant(testing::UniqueDomainId(31), "ros_map_publisher_test");
  // Topics of this process's own: a test elsewhere on a colliding domain id cannot match them.
  const std::string suffix = std::to_string(::getpid());
  CounterSet events;
  ServiceConfig config;
  config.topics.map = "map_" + suffix;
  config.topics.tf = "tf_" + suffix;
  config.topics.perceptual_map = "pmap_" + suffix;
  MapListener listener(participant, config.topics.map);
  {
    config.mode = "head";
    SnapshotStore snapshots;
    RosMapPublisher head(config, participant, snapshots, events);
    snapshots.Publish(FrameWithMaps(1));  // even maps (never in head mode) create nothing
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    EXPECT_EQ(listener.reader.MatchedWriters(), 0);
  }
  config.mode = "auto";
  SnapshotStore snapshots;
  RosMapPublisher base(config, participant, snapshots, events);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(listener.reader.MatchedWriters(), 0) << "no maps yet: no writer";
  snapshots.Publish(FrameWithMaps(1));
  EXPECT_TRUE(WaitFor([&] { return listener.grids > 0; }, std::chrono::seconds(10)));
  EXPECT_EQ(listener.reader.MatchedWriters(), 1);
  EXPECT_EQ(events.Get("ros_map_published"), 1u);
}

}  // namespace
}  // namespace epmap::mapping
