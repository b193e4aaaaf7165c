#include "services/mapping/calibration/calibration_component.h"

#include <spdlog/spdlog.h>

#include "common/dds/ros_conversions.h"
#include "services/mapping/calibration/eye_hand_job.h"
#include "services/mapping/config/camera_chain.h"

namespace epmap::mapping {

namespace {

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Batches beyond this wait in memory are refused (and counted) rather than queued without end.
constexpr size_t kMaxPendingDdsBatches = 256;

}  // namespace

CalibrationComponent::CalibrationComponent(const ServiceConfig& config, SensorState& sensors,
                                           IngestCounters& counters)
    : counters_(counters) {
  if (!config.urdf.empty()) chain_ = LoadCameraChain(config);
  if (!config.state_dir.empty()) {
    try {
      store_ = std::make_unique<CalibrationStore>(config.state_dir);
    } catch (const StoreError& e) {
      throw std::runtime_error(e.what());
    }
    if (const int n = store_->InterruptUnfinishedJobs(NowNs()); n > 0) {
      spdlog::warn("calibration: {} job(s) left unfinished by the previous run are INTERRUPTED", n);
    }
    StereoJobEnvironment stereo;
    stereo.tap = &tap_;
    stereo.sensors = &sensors;
    stereo.chain = chain_ ? &*chain_ : nullptr;
    stereo.urdf_path = config.urdf;
    stereo.dds_domain = config.domain;
    stereo.image_topics = config.topics.left_image + ", " + config.topics.right_image;
    stereo.joints_max_gap_ns = config.joints_max_gap_ns;
    stereo.joints_wait_ns = config.joints_wait_ns;
    stereo.settings = config.calibration;
    runner_ = std::make_unique<JobRunner>(*store_, active_, std::move(stereo),
                                          config.calibration.worker_threads);
    const auto loaded = runner_->LoadActiveModels();
    spdlog::info("calibration state in {}{}", store_->path().string(),
                 loaded.empty() ? std::string("; no active model")
                                : "; active: " + fmt::format("{}", fmt::join(loaded, ", ")));
    dds_writer_ = std::thread([this] { WriteDdsSamples(); });
  } else {
    spdlog::info("calibration disabled: no --state-dir");
  }
  service_ = std::make_unique<CalibrationServiceImpl>(store_.get(), runner_.get(), active_,
                                                      shutting_down_);
}

CalibrationComponent::~CalibrationComponent() {
  Shutdown();
}

void CalibrationComponent::Shutdown() {
  if (shutting_down_.exchange(true)) return;
  if (runner_) runner_->Stop();
  {
    std::lock_guard lock(dds_mutex_);
    dds_stop_ = true;
  }
  dds_arrived_.notify_all();
  if (dds_writer_.joinable()) dds_writer_.join();
}

DdsIngest::EyeHandCallback CalibrationComponent::EyeHandSamplesCallback() {
  return [this](epmap_msgs::msg::EyeHandSamples&& msg) {
    if (!store_) {
      counters_.rejected.Increment("eye_hand_samples:calibration_disabled");
      return;
    }
    Batch batch;
    batch.set = msg.set_name().empty() ? kDefaultSampleSet : msg.set_name();
    if (!CheckSetName(batch.set).empty()) {
      counters_.rejected.Increment("eye_hand_samples:bad_set_name");
      return;
    }
    for (const auto& m : msg.samples()) {
      calibration::EyeHandSample s;
      s.stamp_ns = dds::ToNanoseconds(m.stamp());
      s.xa = Eigen::Vector3d(m.xa()[0], m.xa()[1], m.xa()[2]);
      s.xb = Eigen::Vector3d(m.xb()[0], m.xb()[1], m.xb()[2]);
      s.path = m.path();
      batch.samples.push_back(std::move(s));
    }
    if (batch.samples.empty()) return;
    if (const auto problem = CheckSamples(batch.samples); !problem.empty()) {
      counters_.rejected.Increment("eye_hand_samples:not_finite");
      spdlog::warn("eye-hand samples on DDS refused: {}", problem);
      return;
    }
    {
      std::lock_guard lock(dds_mutex_);
      if (dds_stop_) return;
      if (dds_batches_.size() >= kMaxPendingDdsBatches) {
        counters_.rejected.Increment("eye_hand_samples:writer_behind");
        return;
      }
      dds_batches_.push_back(std::move(batch));
    }
    dds_arrived_.notify_one();
  };
}

void CalibrationComponent::WriteDdsSamples() {
  std::unique_lock lock(dds_mutex_);
  while (true) {
    dds_arrived_.wait(lock, [&] { return dds_stop_ || !dds_batches_.empty(); });
    // Samples already received are written even when stopping: DDS delivered them to us.
    if (dds_batches_.empty()) return;
    Batch batch = std::move(dds_batches_.front());
    dds_batches_.pop_front();
    lock.unlock();
    try {
      const auto r = store_->AddSamples(batch.set, batch.samples);
      spdlog::debug("eye-hand samples from DDS: {} stored in '{}' ({} in the set)", r.stored,
                    batch.set, r.set_total);
    } catch (const std::exception& e) {
      counters_.rejected.Increment("eye_hand_samples:store_failed");
      spdlog::error("eye-hand samples from DDS not stored: {}", e.what());
    }
    lock.lock();
  }
}

}  // namespace epmap::mapping
