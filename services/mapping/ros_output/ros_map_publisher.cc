#include "services/mapping/ros_output/ros_map_publisher.h"

#include <epmap_dds/MarkerArrayPubSubTypes.h>
#include <epmap_dds/OccupancyGridPubSubTypes.h>
#include <epmap_dds/TFMessagePubSubTypes.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "common/dds/endpoints.h"
#include "common/dds/ros_conversions.h"
#include "services/mapping/ros_output/perceptual_map_markers.h"

namespace epmap::mapping {

Eigen::Isometry2d MapToOdom(const Eigen::Isometry2d& T_map_base_corrected,
                            const Eigen::Isometry2d& T_odom_base) {
  return T_map_base_corrected * T_odom_base.inverse();
}

void ToRosGrid(const occupancy::GridExport& grid, int64_t stamp_ns, const std::string& frame,
               nav_msgs::msg::OccupancyGrid* out) {
  out->header().stamp(dds::FromNanoseconds(stamp_ns));
  out->header().frame_id(frame);
  auto& info = out->info();
  info.map_load_time(dds::FromNanoseconds(stamp_ns));
  info.resolution(static_cast<float>(grid.resolution_m));
  info.width(grid.width);
  info.height(grid.height);
  info.origin().position().x(grid.origin_x);
  info.origin().position().y(grid.origin_y);
  info.origin().position().z(0.0);
  info.origin().orientation().x(0.0);
  info.origin().orientation().y(0.0);
  info.origin().orientation().z(0.0);
  info.origin().orientation().w(1.0);
  std::vector<int8_t> data(grid.occupancy.size());
  for (size_t i = 0; i < data.size(); ++i) {
    const uint8_t v = grid.occupancy[i];
    data[i] = v == occupancy::GridExport::kUnknown ? int8_t{-1} : static_cast<int8_t>(v);
  }
  out->data(std::move(data));
}

struct RosMapPublisher::Writers {
  std::optional<dds::Writer<nav_msgs::msg::OccupancyGrid, nav_msgs::msg::OccupancyGridPubSubType>>
      map;
  std::optional<dds::Writer<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType>> tf;
  std::optional<dds::Writer<visualization_msgs::msg::MarkerArray,
                            visualization_msgs::msg::MarkerArrayPubSubType>>
      markers;
  bool created() const { return map || tf || markers; }
};

RosMapPublisher::RosMapPublisher(const ServiceConfig& config, dds::Participant& participant,
                                 const SnapshotStore& snapshots, CounterSet& events,
                                 std::shared_ptr<const mobile_mapping::MapsSnapshot> resumed)
    : config_(config),
      participant_(participant),
      snapshots_(snapshots),
      events_(events),
      resumed_(std::move(resumed)),
      writers_(new Writers) {
  const bool maps_possible =
      config_.maps.enabled && (config_.mode == "auto" || config_.mode == "mobile-base");
  if (maps_possible && (!config_.topics.map.empty() || !config_.topics.tf.empty() ||
                        !config_.topics.perceptual_map.empty())) {
    thread_ = std::thread([this] { Run(); });
  }
}

void RosMapPublisher::CreateWriters() {
  if (!config_.topics.map.empty()) {
    // Depth 1, latched: a reader joining later gets the newest grid only.
    writers_->map.emplace(participant_, dds::RosTopic(config_.topics.map), 1,
                          dds::Durability::kTransientLocal);
  }
  if (!config_.topics.tf.empty()) {
    writers_->tf.emplace(participant_, dds::RosTopic(config_.topics.tf), 100);
  }
  if (!config_.topics.perceptual_map.empty()) {
    // Latched as the grid: RViz started later still draws the newest map.
    writers_->markers.emplace(participant_, dds::RosTopic(config_.topics.perceptual_map), 1,
                              dds::Durability::kTransientLocal);
  }
}

RosMapPublisher::~RosMapPublisher() {
  Stop();
}

void RosMapPublisher::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void RosMapPublisher::Run() {
  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(config_.maps.grid_publish_period_s));
  uint64_t seen_frame = 0;
  std::shared_ptr<const mobile_mapping::MapsSnapshot> published, grid_pending, markers_pending;
  Clock::time_point last_grid{};
  if (resumed_) {
    // The snapshots carry these same maps until a key frame changes them: sent once.
    CreateWriters();
    published = grid_pending = markers_pending = resumed_;
  }
  while (!stop_) {
    const auto snapshot = snapshots_.WaitNewer(seen_frame, std::chrono::milliseconds(200));
    if (!snapshot || snapshot->frame_index <= seen_frame) {
      // Nothing newer (or the store closed at shutdown): do not spin.
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    } else {
      seen_frame = snapshot->frame_index;
      if (snapshot->maps) {
        // The writers appear with the first maps: a head (or an `auto` service that never
        // receives odometry) announces no rt/map or rt/tf that would stay silent.
        if (!writers_->created()) CreateWriters();
        if (snapshot->maps != published) {
          published = snapshot->maps;
          grid_pending = markers_pending = snapshot->maps;
        }
        // Every frame, at its own time (the correction holds until the next key frame).
        PublishTransform(*snapshot->maps, std::max(snapshot->stamp_ns, snapshot->maps->stamp_ns));
      }
    }
    // The grid (and the perceptual map beside it) at most once a period, the newest one; a
    // change that arrives within the period goes out when it ends.
    // The perceptual map's markers are built only while a reader (RViz) is matched: building
    // them computes III-D's boundary, which grows with the map (about 40 ms per snapshot after
    // 750 m), for nobody otherwise. The newest waits and goes out at the first period's end
    // after a reader matches (within a second), as a late joiner of the latched topic expects.
    if ((grid_pending || markers_pending) && Clock::now() - last_grid >= period) {
      bool sent = false;
      if (grid_pending) {
        PublishGrid(*grid_pending);
        grid_pending.reset();
        sent = true;
      }
      if (markers_pending && !writers_->markers) markers_pending.reset();
      if (markers_pending && writers_->markers->MatchedReaders() > 0) {
        PublishMarkers(*markers_pending);
        markers_pending.reset();
        sent = true;
      }
      if (sent) last_grid = Clock::now();
    }
  }
}

void RosMapPublisher::PublishGrid(const mobile_mapping::MapsSnapshot& maps) {
  if (!writers_->map) return;
  const occupancy::GridExport g = maps.grid.Export();
  if (g.width == 0 || g.height == 0) return;  // no known cell yet
  nav_msgs::msg::OccupancyGrid msg;
  ToRosGrid(g, maps.stamp_ns, config_.maps.map_frame, &msg);
  if (writers_->map->Write(msg)) {
    events_.Increment("ros_map_published");
  } else {
    spdlog::warn("rt/map: the grid ({}x{}) could not be written", g.width, g.height);
  }
}

void RosMapPublisher::PublishMarkers(const mobile_mapping::MapsSnapshot& maps) {
  if (!writers_->markers) return;
  visualization_msgs::msg::MarkerArray msg;
  ToRosMarkers(maps.perceptual(), maps.stamp_ns, config_.maps.map_frame, &msg);
  if (writers_->markers->Write(msg)) {
    events_.Increment("ros_perceptual_map_published");
  } else {
    spdlog::warn("{}: the perceptual map ({} segments) could not be written",
                 config_.topics.perceptual_map, maps.perceptual().segments.size());
  }
}

void RosMapPublisher::PublishTransform(const mobile_mapping::MapsSnapshot& maps, int64_t stamp_ns) {
  if (!writers_->tf || maps.poses.empty()) return;
  const auto& r = maps.poses.back();
  const Eigen::Isometry2d T = MapToOdom(r.T_world_base, r.T_world_base_odometry);
  geometry_msgs::msg::TransformStamped t;
  t.header().stamp(dds::FromNanoseconds(stamp_ns));
  t.header().frame_id(config_.maps.map_frame);
  t.child_frame_id(config_.maps.odom_frame);
  t.transform_value().translation().x(T.translation().x());
  t.transform_value().translation().y(T.translation().y());
  t.transform_value().translation().z(0.0);
  const double yaw = std::atan2(T.linear()(1, 0), T.linear()(0, 0));
  t.transform_value().rotation().x(0.0);
  t.transform_value().rotation().y(0.0);
  t.transform_value().rotation().z(std::sin(yaw / 2));
  t.transform_value().rotation().w(std::cos(yaw / 2));
  tf2_msgs::msg::TFMessage msg;
  msg.transforms().push_back(t);
  if (writers_->tf->Write(msg)) events_.Increment("ros_tf_published");
}

}  // namespace epmap::mapping
