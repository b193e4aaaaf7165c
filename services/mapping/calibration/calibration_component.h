#pragma once
// The calibration service as one part of epmapd: the SQLite store in the state folder, the job
// runner, the active models, the raw-frame tap for stereo jobs, the writer of eye-hand samples
// arriving over DDS, and the gRPC service. MappingService builds it, registers grpc_service(),
// hands active_models() and frame_tap() to the pipeline and EyeHandSamplesCallback() to DDS
// ingest. Without a state folder only the (empty) active models and the tap exist and the gRPC
// service answers FAILED_PRECONDITION.

#include <grpcpp/impl/service_type.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "perception/kinematics/urdf_chain.h"
#include "services/mapping/calibration/active_models.h"
#include "services/mapping/calibration/calibration_service.h"
#include "services/mapping/calibration/calibration_store.h"
#include "services/mapping/calibration/frame_tap.h"
#include "services/mapping/calibration/job_runner.h"
#include "services/mapping/config/service_config.h"
#include "services/mapping/ingest/dds_ingest.h"
#include "services/mapping/ingest/sensor_state.h"

namespace epmap::mapping {

class CalibrationComponent {
 public:
  // Opens the store (throws std::runtime_error with the reason if the state folder cannot be
  // used), marks jobs a previous process left unfinished INTERRUPTED, loads the active models
  // and starts the job workers.
  CalibrationComponent(const ServiceConfig& config, SensorState& sensors, IngestCounters& counters);
  ~CalibrationComponent();

  bool enabled() const { return store_ != nullptr; }
  grpc::Service* grpc_service() { return service_.get(); }
  ActiveModels& active_models() { return active_; }
  RawFrameTap& frame_tap() { return tap_; }
  // For DdsIngest::SetEyeHandCallback: samples from the DDS topic are checked like AddSamples'
  // and stored by a writer thread (the DDS listener never waits for the disk).
  DdsIngest::EyeHandCallback EyeHandSamplesCallback();

  // Ends watches, interrupts running jobs, stops the writer (idempotent).
  void Shutdown();

 private:
  void WriteDdsSamples();

  IngestCounters& counters_;
  std::atomic<bool> shutting_down_{false};
  ActiveModels active_;
  RawFrameTap tap_;
  std::optional<kinematics::UrdfChain> chain_;  // the stereo jobs' own copy
  std::unique_ptr<CalibrationStore> store_;
  std::unique_ptr<JobRunner> runner_;
  std::unique_ptr<CalibrationServiceImpl> service_;

  // DDS samples waiting to be written.
  struct Batch {
    std::string set;
    std::vector<calibration::EyeHandSample> samples;
  };
  std::mutex dds_mutex_;
  std::condition_variable dds_arrived_;
  std::deque<Batch> dds_batches_;
  bool dds_stop_ = false;
  std::thread dds_writer_;
};

}  // namespace epmap::mapping
