#include "services/mapping/calibration/job_runner.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>

#include "services/mapping/api/proto_conversions.h"
#include "services/mapping/calibration/eye_hand_job.h"

namespace epmap::mapping {

namespace {

using Clock = std::chrono::steady_clock;
// Watchers hear about progress at most this often (state changes at once).
constexpr auto kPublishEvery = std::chrono::milliseconds(50);

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string Cm(double m) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f cm", 100 * m);
  return buf;
}

}  // namespace

bool IsFinished(v1::JobState state) {
  return state == v1::SUCCEEDED || state == v1::FAILED || state == v1::CANCELLED ||
         state == v1::INTERRUPTED;
}

void InstallActiveModel(const v1::Model& model, ActiveModels& active) {
  try {
    if (model.kind() == v1::EYE_HAND) {
      active.SetEyeHand(std::make_shared<const ActiveModels::EyeHand>(ActiveModels::EyeHand{
          model.id(), calibration::EyeHandModel::FromJson(model.parameters_json())}));
    } else if (model.kind() == v1::STEREO_EXTRINSICS) {
      active.SetStereo(std::make_shared<const ActiveModels::Stereo>(ActiveModels::Stereo{
          model.id(), StereoCorrectionModel::FromJson(model.parameters_json())}));
    } else {
      throw std::invalid_argument("unknown kind");
    }
  } catch (const std::exception& e) {
    throw std::invalid_argument("model " + model.id() + " cannot be loaded: " + e.what());
  }
}

void ClearActiveModel(v1::JobKind kind, ActiveModels& active) {
  if (kind == v1::EYE_HAND) active.SetEyeHand(nullptr);
  if (kind == v1::STEREO_EXTRINSICS) active.SetStereo(nullptr);
}

JobRunner::JobRunner(CalibrationStore& store, ActiveModels& active, StereoJobEnvironment stereo,
                     int workers)
    : store_(store), active_(active), stereo_(std::move(stereo)) {
  for (int i = 0; i < std::max(1, workers); ++i) workers_.emplace_back([this] { Work(); });
}

JobRunner::~JobRunner() {
  Stop();
}

v1::Job JobRunner::Submit(const v1::JobSpec& spec_in, bool activate_on_success) {
  v1::JobSpec spec = spec_in;
  v1::JobKind kind = v1::JOB_KIND_UNSPECIFIED;
  std::string problem;
  if (spec.has_eye_hand()) {
    kind = v1::EYE_HAND;
    problem = CheckEyeHandSpec(spec.eye_hand());
    *spec.mutable_eye_hand() = WithDefaults(spec.eye_hand());
  } else if (spec.has_stereo_extrinsics()) {
    kind = v1::STEREO_EXTRINSICS;
    problem = CheckStereoSpec(spec.stereo_extrinsics());
    *spec.mutable_stereo_extrinsics() = WithDefaults(spec.stereo_extrinsics(), stereo_.settings);
  } else {
    problem = "the job spec must be eye_hand or stereo_extrinsics";
  }
  if (!problem.empty()) throw std::invalid_argument(problem);

  std::lock_guard lock(mutex_);
  if (stopping_) throw StoreError(StoreError::Code::kFailedPrecondition, "the service is stopping");
  auto live = std::make_shared<Live>();
  live->job = store_.CreateJob(kind, spec, activate_on_success, NowNs());
  live_[live->job.id()] = live;
  queue_.push_back(live->job.id());
  queued_.notify_one();
  return live->job;
}

std::optional<v1::Job> JobRunner::Get(const std::string& id) const {
  {
    std::lock_guard lock(mutex_);
    if (const auto it = live_.find(id); it != live_.end()) return it->second->job;
  }
  return store_.GetJob(id);
}

std::vector<v1::Job> JobRunner::List(uint32_t limit) const {
  auto jobs = store_.ListJobs(limit);
  std::lock_guard lock(mutex_);
  for (auto& j : jobs) {
    if (const auto it = live_.find(j.id()); it != live_.end()) j = it->second->job;
  }
  return jobs;
}

v1::Job JobRunner::Cancel(const std::string& id) {
  std::lock_guard lock(mutex_);
  const auto it = live_.find(id);
  if (it == live_.end()) {
    auto job = store_.GetJob(id);
    if (!job) throw StoreError(StoreError::Code::kNotFound, "no job '" + id + "'");
    return *job;  // already finished: nothing to cancel
  }
  const auto live = it->second;
  live->cancel = true;
  if (live->job.state() == v1::QUEUED) {
    queue_.erase(std::remove(queue_.begin(), queue_.end(), id), queue_.end());
    live->job.set_state(v1::CANCELLED);
    live->job.set_stage("cancelled");
    live->job.set_message("cancelled before it started (CancelJob)");
    live->job.set_finished_ns(NowNs());
    FinishLocked(live);
  }
  return live->job;
}

bool JobRunner::Watch(const std::string& id, uint64_t* version, std::chrono::milliseconds timeout,
                      v1::Job* job) const {
  std::unique_lock lock(mutex_);
  const auto it = live_.find(id);
  if (it == live_.end()) {
    lock.unlock();
    auto stored = store_.GetJob(id);
    if (!stored) return false;
    *job = std::move(*stored);
    // Finished jobs never change again: one version number above any live one.
    *version = ~0ull;
    return true;
  }
  const auto live = it->second;  // outlives its removal from live_ while we wait
  changed_.wait_for(lock, timeout, [&] { return live->version != *version || stopping_; });
  *job = live->job;
  *version = IsFinished(live->job.state()) ? ~0ull : live->version;
  return true;
}

void JobRunner::Stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && workers_.empty()) return;
    stopping_ = true;
    for (auto& [_, live] : live_) live->cancel = true;
  }
  queued_.notify_all();
  changed_.notify_all();
  for (auto& w : workers_) {
    if (w.joinable()) w.join();
  }
  workers_.clear();
  // Jobs that never started.
  std::lock_guard lock(mutex_);
  while (!live_.empty()) {
    const auto live = live_.begin()->second;
    live->job.set_state(v1::INTERRUPTED);
    live->job.set_stage("interrupted");
    live->job.set_message("the service stopped before the job started; start it again");
    live->job.set_finished_ns(NowNs());
    FinishLocked(live);
  }
  queue_.clear();
}

v1::Model JobRunner::Activate(const std::string& model_id) {
  std::lock_guard activation(activation_mutex_);
  const auto model = store_.GetModel(model_id);
  if (!model) throw StoreError(StoreError::Code::kNotFound, "no model '" + model_id + "'");
  ActiveModels scratch;
  InstallActiveModel(*model, scratch);  // throws if it cannot be loaded: not recorded then
  const v1::Model active = store_.Activate(model_id, NowNs());
  InstallActiveModel(active, active_);
  spdlog::info("calibration: {} activated", model_id);
  return active;
}

std::optional<v1::Model> JobRunner::Rollback(v1::JobKind kind) {
  std::lock_guard activation(activation_mutex_);
  auto restored = store_.Rollback(kind, NowNs());
  if (restored) {
    InstallActiveModel(*restored, active_);
    spdlog::info("calibration: rolled back to {}", restored->id());
  } else {
    ClearActiveModel(kind, active_);
    spdlog::info("calibration: rolled back; no {} model active", JobKindName(kind));
  }
  return restored;
}

std::vector<std::string> JobRunner::LoadActiveModels() {
  std::lock_guard activation(activation_mutex_);
  std::vector<std::string> loaded;
  for (const auto kind : {v1::EYE_HAND, v1::STEREO_EXTRINSICS}) {
    const auto model = store_.ActiveModel(kind);
    if (!model) continue;
    try {
      InstallActiveModel(*model, active_);
      loaded.push_back(model->id());
    } catch (const std::exception& e) {
      spdlog::error("calibration: the active {} model is not used: {}", JobKindName(kind),
                    e.what());
    }
  }
  return loaded;
}

void JobRunner::Work() {
  while (true) {
    std::shared_ptr<Live> live;
    {
      std::unique_lock lock(mutex_);
      queued_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      live = live_.at(queue_.front());
      queue_.pop_front();
      live->job.set_state(v1::RUNNING);
      live->job.set_stage("starting");
      live->job.set_started_ns(NowNs());
      live->version++;
      try {
        store_.UpdateJob(live->job);
      } catch (const std::exception& e) {
        spdlog::error("calibration: cannot record {} as running: {}", live->job.id(), e.what());
      }
    }
    changed_.notify_all();
    Run(live);
  }
}

void JobRunner::Run(const std::shared_ptr<Live>& live) {
  // Called from inside the fits, on this worker thread.
  const calibration::ProgressCallback progress = [&](const calibration::Progress& p) {
    bool publish = false;
    {
      std::lock_guard lock(mutex_);
      auto& j = live->job;
      publish = j.stage() != p.stage || Clock::now() - live->last_published >= kPublishEvery;
      j.set_stage(p.stage);
      j.set_iteration(p.iteration);
      j.set_cost(p.cost);
      j.set_progress(std::clamp(p.fraction, 0.0, 1.0));
      if (publish) {
        live->version++;
        live->last_published = Clock::now();
      }
    }
    if (publish) changed_.notify_all();
    return !live->cancel.load();
  };

  v1::Model model;
  std::string outcome;
  try {
    if (live->job.kind() == v1::EYE_HAND) {
      RunEyeHand(*live, progress, &model);
    } else {
      RunStereo(*live, progress, &model);
    }
    // A cancel that came while the fit was finishing still means "no model".
    if (live->cancel.load()) {
      throw calibration::CalibrationError(calibration::ErrorCode::kCancelled, "cancelled");
    }
    // The model and the job's success are one transaction: no model without a SUCCEEDED job.
    v1::Job finished;
    {
      std::lock_guard lock(mutex_);
      finished = live->job;
    }
    finished.set_stage("done");
    const bool activate = finished.activate_on_success();
    if (activate) {
      ActiveModels scratch;  // the model must load before it is recorded as active
      InstallActiveModel(model, scratch);
    }
    std::unique_lock activation(activation_mutex_, std::defer_lock);
    if (activate) activation.lock();
    const v1::Model stored = store_.FinishJobWithModel(finished, model, activate, NowNs());
    if (activate) InstallActiveModel(stored, active_);
    if (activate) activation.unlock();
    std::lock_guard lock(mutex_);
    live->job = finished;
    outcome = "succeeded: " + stored.id() + (activate ? " (activated)" : "");
    live->version++;
    live_.erase(live->job.id());
  } catch (const calibration::CalibrationError& e) {
    std::lock_guard lock(mutex_);
    auto& j = live->job;
    if (e.code() == calibration::ErrorCode::kCancelled) {
      j.set_state(stopping_ ? v1::INTERRUPTED : v1::CANCELLED);
      j.set_message(stopping_ ? "the service stopped while the job ran; start it again"
                              : "cancelled while running (CancelJob)");
    } else {
      j.set_state(v1::FAILED);
      j.set_message(e.what());
    }
    j.set_finished_ns(NowNs());
    j.set_stage(v1::JobState_Name(j.state()));
    outcome = v1::JobState_Name(j.state()) + ": " + j.message();
    FinishLocked(live);
  } catch (const std::exception& e) {
    std::lock_guard lock(mutex_);
    auto& j = live->job;
    j.set_state(v1::FAILED);
    j.set_message(std::string("internal error: ") + e.what());
    j.set_finished_ns(NowNs());
    j.set_stage("FAILED");
    outcome = "FAILED: " + j.message();
    FinishLocked(live);
  }
  changed_.notify_all();
  spdlog::info("calibration {} ({}) {}", live->job.id(), JobKindName(live->job.kind()), outcome);
}

void JobRunner::FinishLocked(const std::shared_ptr<Live>& live) {
  try {
    store_.UpdateJob(live->job);
  } catch (const std::exception& e) {
    spdlog::error("calibration: cannot record the end of {}: {}", live->job.id(), e.what());
  }
  live->version++;
  live_.erase(live->job.id());
  changed_.notify_all();
}

void JobRunner::RunEyeHand(Live& live, const calibration::ProgressCallback& progress,
                           v1::Model* model) {
  const v1::EyeHandSpec& spec = live.job.spec().eye_hand();  // immutable after Submit
  progress({"loading samples", 0, 0.0, 0.0});
  const auto samples = store_.Samples(spec.set());
  const auto r = RunEyeHandJob(spec, samples, progress);
  model->set_kind(v1::EYE_HAND);
  *model->mutable_errors() = r.errors;
  model->set_description(r.description);
  model->set_parameters_json(r.fit.model.ToJson());
  std::lock_guard lock(mutex_);
  *live.job.mutable_errors() = r.errors;
  live.job.set_message(
      r.errors.holdout_count() > 0
          ? "hold-out mean error " + Cm(r.errors.holdout_mean_m()) + " (uncalibrated " +
                Cm(r.errors.initial_mean_m()) + "), training " + Cm(r.errors.train_mean_m())
          : "training mean error " + Cm(r.errors.train_mean_m()) + " (uncalibrated " +
                Cm(r.errors.initial_mean_m()) + "), no hold-out");
}

void JobRunner::RunStereo(Live& live, const calibration::ProgressCallback& progress,
                          v1::Model* model) {
  const auto r = RunStereoJob(live.job.spec().stereo_extrinsics(), stereo_, progress);
  model->set_kind(v1::STEREO_EXTRINSICS);
  *model->mutable_errors() = r.errors;
  model->set_description(r.description);
  model->set_parameters_json(r.model.ToJson());
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "median vertical offset %.3f px after rectification (kinematic prior %.3f px); "
                "%d of %d frames used",
                r.model.median_vertical_offset_px, r.model.prior_median_vertical_offset_px,
                r.model.frames_used, r.model.frames_used + r.model.frames_failed);
  std::lock_guard lock(mutex_);
  *live.job.mutable_errors() = r.errors;
  live.job.set_message(buf);
}

}  // namespace epmap::mapping
