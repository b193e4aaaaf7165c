#pragma once
// The maps for ROS 2 planners on DDS, beside the gRPC API: in mobile-base mode epmapd publishes
// its occupancy grid as nav_msgs/OccupancyGrid on rt/map (reliable, transient local: a planner
// or RViz that starts later still gets the last grid, as from map_server) and its heading and
// position correction as the map -> odom transform on rt/tf (what a ROS localiser publishes, so
// nav2 and RViz place the odometry in the map). A thread of its own follows the snapshots; the
// pipeline never waits for DDS. The correction changes at key frames only, but map -> odom goes
// out with every processed frame, stamped with that frame's time: tf lookups at sensor time
// then never extrapolate past the last key frame while the robot stands still. With each grid
// the perceptual map goes out as a visualization_msgs/MarkerArray (perceptual_map_markers.h)
// while a reader (RViz) is matched; with none, the newest waits for one (building it costs
// III-D's boundary, which grows with the map).

#include <Eigen/Geometry>
#include <atomic>
#include <chrono>
#include <memory>
#include <thread>

#include "common/dds/participant.h"
#include "services/mapping/config/service_config.h"
#include "services/mapping/ingest/counters.h"
#include "services/mapping/pipeline/map_snapshot.h"

namespace nav_msgs::msg {
class OccupancyGrid;
}
namespace tf2_msgs::msg {
class TFMessage;
}

namespace epmap::mapping {

// map -> odom: the corrected base pose times the inverse of the odometry's, at the same key
// frame (both in the frame the first key frame's odometry is in, which the map starts as).
Eigen::Isometry2d MapToOdom(const Eigen::Isometry2d& T_map_base_corrected,
                            const Eigen::Isometry2d& T_odom_base);

// The grid export in ROS's layout: row-major from the lowest y row (as the export), -1 unknown,
// 0..100 occupancy; origin = the lower-left corner of cell (0, 0), no rotation.
void ToRosGrid(const occupancy::GridExport& grid, int64_t stamp_ns, const std::string& frame,
               nav_msgs::msg::OccupancyGrid* out);

class RosMapPublisher {
 public:
  // Publishes on config.topics.map / .tf / .perceptual_map (an empty name: that one is off)
  // through participant, counting in events: ros_map_published, ros_tf_published,
  // ros_perceptual_map_published. The writers are created with the
  // first snapshot that carries maps (mobile-base mode); in head or static mode, or with the
  // maps disabled, nothing is created at all. `resumed`: maps the service resumed from its
  // state dir at start-up (or null); their grid and perceptual map go out at once, so that a
  // planner restarted with the robot has its map before the first frame (map -> odom waits for
  // a key frame: until then the odometry is not known to continue the saved maps).
  RosMapPublisher(const ServiceConfig& config, dds::Participant& participant,
                  const SnapshotStore& snapshots, CounterSet& events,
                  std::shared_ptr<const mobile_mapping::MapsSnapshot> resumed = nullptr);
  ~RosMapPublisher();  // stops the thread
  RosMapPublisher(const RosMapPublisher&) = delete;
  RosMapPublisher& operator=(const RosMapPublisher&) = delete;

  void Stop();

 private:
  struct Writers;
  void Run();
  void CreateWriters();
  void PublishGrid(const mobile_mapping::MapsSnapshot& maps);     // rt/map
  void PublishMarkers(const mobile_mapping::MapsSnapshot& maps);  // the perceptual map, for RViz
  // rt/tf: map -> odom from the newest key frame's correction, stamped stamp_ns.
  void PublishTransform(const mobile_mapping::MapsSnapshot& maps, int64_t stamp_ns);

  const ServiceConfig config_;
  dds::Participant& participant_;
  const SnapshotStore& snapshots_;
  CounterSet& events_;
  std::shared_ptr<const mobile_mapping::MapsSnapshot> resumed_;
  std::unique_ptr<Writers> writers_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace epmap::mapping
