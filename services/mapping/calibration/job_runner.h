#pragma once
// Runs calibration jobs on the service's own worker threads (never on gRPC threads): a job is
// persisted QUEUED when submitted, RUNNING when a worker takes it, and SUCCEEDED (with its new
// model, in the same transaction), FAILED (with the reason), CANCELLED or INTERRUPTED (the
// service stopped) when it ends. Progress lives in memory and is published to watchers at most
// every 50 ms; only state changes are written to the store. Cancellation goes through the
// algorithms' ProgressCallback, which the fits call at least once per solver evaluation.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "services/mapping/calibration/active_models.h"
#include "services/mapping/calibration/calibration_store.h"
#include "services/mapping/calibration/stereo_job.h"

namespace epmap::mapping {

// Parses a stored model and makes it the active one of its kind. Throws std::invalid_argument
// when its parameters cannot be read (the caller must then not record the activation).
void InstallActiveModel(const v1::Model& model, ActiveModels& active);
// Clears the active model of `kind` in memory.
void ClearActiveModel(v1::JobKind kind, ActiveModels& active);

bool IsFinished(v1::JobState state);

class JobRunner {
 public:
  // `stereo` tells stereo jobs where the live frames, CameraInfo and joints come from.
  JobRunner(CalibrationStore& store, ActiveModels& active, StereoJobEnvironment stereo,
            int workers);
  ~JobRunner();
  JobRunner(const JobRunner&) = delete;
  JobRunner& operator=(const JobRunner&) = delete;

  // Validates the spec (std::invalid_argument with the reason), persists the job QUEUED with
  // every default made explicit, and returns at once.
  v1::Job Submit(const v1::JobSpec& spec, bool activate_on_success);
  // The job as it is now (live progress while it runs); nullopt for an unknown id.
  std::optional<v1::Job> Get(const std::string& id) const;
  // Newest first, live progress overlaid.
  std::vector<v1::Job> List(uint32_t limit) const;
  // Asks the job to stop. A queued job is CANCELLED at once, a running one as soon as its fit
  // next reports progress; a finished one is returned unchanged. Throws StoreError(kNotFound).
  v1::Job Cancel(const std::string& id);
  // Waits up to `timeout` until the job differs from version `*version` (start with 0), then
  // fills *job and *version. A finished job returns at once. False for an unknown id.
  bool Watch(const std::string& id, uint64_t* version, std::chrono::milliseconds timeout,
             v1::Job* job) const;
  // Stops the workers: running and queued jobs end INTERRUPTED. Idempotent.
  void Stop();

  // Model activation, serialised with the jobs' activate_on_success so that the store and the
  // in-memory ActiveModels always agree. A model is recorded active only if it loads. Throw
  // StoreError (kNotFound, kFailedPrecondition) or std::invalid_argument (unloadable model).
  v1::Model Activate(const std::string& model_id);
  // Undoes the newest activation of `kind`; returns the model active now (nullopt: none).
  std::optional<v1::Model> Rollback(v1::JobKind kind);
  // Puts the models the store records as active into ActiveModels (at start). Returns their
  // ids; a model that cannot be loaded is logged and skipped.
  std::vector<std::string> LoadActiveModels();

 private:
  struct Live {
    v1::Job job;
    uint64_t version = 1;
    std::atomic<bool> cancel{false};
    std::chrono::steady_clock::time_point last_published;
  };
  void Work();
  void Run(const std::shared_ptr<Live>& live);
  void RunEyeHand(Live& live, const calibration::ProgressCallback& progress, v1::Model* model);
  void RunStereo(Live& live, const calibration::ProgressCallback& progress, v1::Model* model);
  // Ends a job: persists it, publishes it to watchers and forgets it (caller holds mutex_).
  void FinishLocked(const std::shared_ptr<Live>& live);

  CalibrationStore& store_;
  ActiveModels& active_;
  const StereoJobEnvironment stereo_;
  std::mutex activation_mutex_;  // store + ActiveModels updates of the active models
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;  // a job changed (watchers)
  std::condition_variable queued_;           // a job was queued (workers)
  std::deque<std::string> queue_;
  std::map<std::string, std::shared_ptr<Live>> live_;  // queued and running jobs
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace epmap::mapping
