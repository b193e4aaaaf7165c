#pragma once
// The pipeline thread: takes assembled stereo frames from the queue, rectifies them (from
// CameraInfo or the configured camera), finds the camera pose (URDF chain + joints, or
// odometry), computes the disparity and publishes an immutable snapshot.

#include <atomic>
#include <memory>
#include <optional>
#include <thread>

#include "perception/kinematics/urdf_chain.h"
#include "perception/stereo/rectification.h"
#include "perception/stereo/sgbm.h"
#include "services/mapping/config/service_config.h"
#include "services/mapping/ingest/bounded_queue.h"
#include "services/mapping/ingest/dds_ingest.h"
#include "services/mapping/ingest/sensor_state.h"
#include "services/mapping/pipeline/map_snapshot.h"
#include "services/mapping/pipeline/stage_stats.h"

namespace epmap::mapping {

class Pipeline {
 public:
  // Throws std::runtime_error if the configured URDF cannot be loaded.
  Pipeline(const ServiceConfig& config, BoundedQueue<StereoFrame>& queue, SensorState& sensors,
           IngestCounters& counters, SnapshotStore& snapshots);
  ~Pipeline();

  void Start();
  void Stop();  // finishes the frame in hand, then returns

  uint64_t frames_processed() const { return processed_.load(); }
  const RollingStats& stage_ms() const { return stage_ms_; }
  const RollingStats& figures() const { return figures_; }  // latency_ms, recomputed_share
  uint64_t full_refreshes() const { return full_refreshes_.load(); }
  CounterSet& events() { return events_; }
  std::string mode() const;

 private:
  void Run();
  void Process(StereoFrame& frame);
  // The rectifier for the current calibration; nullptr (and a counted rejection) if none.
  const stereo::Rectifier* CurrentRectifier(const StereoFrame& frame);
  std::optional<Eigen::Isometry3d> PoseAt(int64_t stamp_ns);

  const ServiceConfig config_;
  BoundedQueue<StereoFrame>& queue_;
  SensorState& sensors_;
  IngestCounters& counters_;
  SnapshotStore& snapshots_;

  std::optional<kinematics::UrdfChain> chain_;
  stereo::SgbmMatcher matcher_;
  std::optional<stereo::Rectifier> rectifier_;
  uint64_t rectifier_version_ = ~0ull;

  RollingStats stage_ms_;
  RollingStats figures_;
  CounterSet events_;
  std::atomic<uint64_t> processed_{0};
  std::atomic<uint64_t> full_refreshes_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace epmap::mapping
