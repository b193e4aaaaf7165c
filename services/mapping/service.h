#pragma once
// epmapd as an object: DDS ingest -> bounded queue -> pipeline thread -> snapshots, and the
// gRPC server reading them. main.cc only parses flags, builds this and waits for a signal.

#include <grpcpp/server.h>

#include <chrono>
#include <memory>
#include <string>

#include "services/mapping/calibration/calibration_component.h"
#include "services/mapping/config/service_config.h"
#include "services/mapping/ingest/bounded_queue.h"
#include "services/mapping/ingest/dds_ingest.h"
#include "services/mapping/ingest/sensor_state.h"
#include "services/mapping/pipeline/map_snapshot.h"
#include "services/mapping/pipeline/pipeline.h"
#include "services/mapping/ros_output/ros_map_publisher.h"
#include "services/mapping/ros_output/ros_perception_publisher.h"

namespace epmap::mapping {

class MapServiceImpl;

class MappingService {
 public:
  // Builds every part; throws std::runtime_error with the reason if one cannot start (bad
  // URDF, port in use, DDS domain unusable).
  explicit MappingService(const ServiceConfig& config);
  ~MappingService();

  // The address the gRPC server actually bound (useful with port 0).
  const std::string& bound_address() const { return bound_address_; }
  // Stops serving and joins every thread (idempotent).
  void Shutdown();

  // Read by the API.
  const ServiceConfig& config() const { return config_; }
  const SnapshotStore& snapshots() const { return snapshots_; }
  IngestCounters& counters() { return counters_; }
  DdsIngest& ingest() { return *ingest_; }
  Pipeline& pipeline() { return *pipeline_; }
  const BoundedQueue<StereoFrame>& queue() const { return queue_; }
  // Calibration jobs, models and the active models the pipeline applies.
  CalibrationComponent& calibration() { return *calibration_; }
  double uptime_s() const;
  bool shutting_down() const { return shutting_down_.load(); }

 private:
  const ServiceConfig config_;
  const std::chrono::steady_clock::time_point started_;
  IngestCounters counters_;
  BoundedQueue<StereoFrame> queue_;
  SensorState sensors_;
  SnapshotStore snapshots_;
  std::unique_ptr<CalibrationComponent> calibration_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<DdsIngest> ingest_;
  std::unique_ptr<RosMapPublisher> ros_maps_;  // rt/map and rt/tf (mobile-base mode)
  // rt/epmap/disparity and rt/epmap/unexpected_mask (every mode, while a reader listens)
  std::unique_ptr<RosPerceptionPublisher> ros_perception_;
  std::unique_ptr<MapServiceImpl> map_service_;
  std::unique_ptr<grpc::Server> server_;
  std::string bound_address_;
  std::atomic<bool> shutting_down_{false};
};

}  // namespace epmap::mapping
