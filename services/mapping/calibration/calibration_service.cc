#include "services/mapping/calibration/calibration_service.h"

#include <cmath>

#include "services/mapping/api/proto_conversions.h"
#include "services/mapping/calibration/eye_hand_job.h"

namespace epmap::mapping {

namespace {

constexpr uint32_t kDefaultJobLimit = 100;
constexpr uint32_t kMaxJobLimit = 10000;
constexpr size_t kMaxSetName = 128;
// How long one wait of WatchJob lasts before it looks at the client and the service again.
constexpr auto kWatchSlice = std::chrono::milliseconds(200);

const grpc::Status kNoStateDir(grpc::StatusCode::FAILED_PRECONDITION,
                               "no --state-dir configured: epmapd keeps calibration samples, jobs "
                               "and models in a state folder; start it with --state-dir DIR (or "
                               "state.dir in the config)");

// Runs `f`, turning the store's and the runner's exceptions into statuses.
template <class F>
grpc::Status Guard(F&& f) {
  try {
    return f();
  } catch (const StoreError& e) {
    switch (e.code()) {
      case StoreError::Code::kNotFound:
        return {grpc::StatusCode::NOT_FOUND, e.what()};
      case StoreError::Code::kFailedPrecondition:
        return {grpc::StatusCode::FAILED_PRECONDITION, e.what()};
      default:
        return {grpc::StatusCode::INTERNAL, e.what()};
    }
  } catch (const std::invalid_argument& e) {
    return {grpc::StatusCode::INVALID_ARGUMENT, e.what()};
  } catch (const std::exception& e) {
    return {grpc::StatusCode::INTERNAL, e.what()};
  }
}

calibration::EyeHandSample FromProto(const v1::EyeHandSample& p) {
  calibration::EyeHandSample s;
  s.stamp_ns = p.stamp_ns();
  s.xa = Eigen::Vector3d(p.xa().x(), p.xa().y(), p.xa().z());
  s.xb = Eigen::Vector3d(p.xb().x(), p.xb().y(), p.xb().z());
  s.path = p.path();
  return s;
}

std::string Format(const Eigen::Vector3d& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%g, %g, %g)", v.x(), v.y(), v.z());
  return buf;
}

v1::JobKind KindOrDefault(v1::JobKind kind) {
  return kind == v1::JOB_KIND_UNSPECIFIED ? v1::EYE_HAND : kind;
}

}  // namespace

std::string CheckSamples(const std::vector<calibration::EyeHandSample>& samples) {
  for (size_t i = 0; i < samples.size(); ++i) {
    const auto& s = samples[i];
    if (!s.xa.allFinite())
      return "sample " + std::to_string(i) + ": xa " + Format(s.xa) + " is not finite";
    if (!s.xb.allFinite())
      return "sample " + std::to_string(i) + ": xb " + Format(s.xb) + " is not finite";
  }
  return "";
}

std::string CheckSetName(const std::string& name) {
  if (name.empty() || name.size() > kMaxSetName) {
    return "a sample set name must have 1.." + std::to_string(kMaxSetName) + " characters";
  }
  for (const unsigned char c : name) {
    if (c < 0x20 || c == 0x7f) return "the sample set name has a control character";
  }
  return "";
}

grpc::Status CalibrationServiceImpl::AddSamples(grpc::ServerContext*,
                                                const v1::AddSamplesRequest* request,
                                                v1::AddSamplesResponse* response) {
  if (!store_) return kNoStateDir;
  const std::string set = request->set().empty() ? kDefaultSampleSet : request->set();
  if (auto problem = CheckSetName(set); !problem.empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT, problem};
  }
  if (request->samples_size() == 0) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "AddSamples needs at least one sample"};
  }
  std::vector<calibration::EyeHandSample> samples;
  samples.reserve(static_cast<size_t>(request->samples_size()));
  for (int i = 0; i < request->samples_size(); ++i) {
    const auto& p = request->samples(i);
    if (!p.has_xa() || !p.has_xb()) {
      return {grpc::StatusCode::INVALID_ARGUMENT,
              "sample " + std::to_string(i) + " lacks " + (p.has_xa() ? "xb" : "xa")};
    }
    samples.push_back(FromProto(p));
  }
  if (auto problem = CheckSamples(samples); !problem.empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT, problem + "; nothing was stored"};
  }
  return Guard([&] {
    // Committed (fsync) before we answer: an acknowledged sample survives a crash.
    const auto r = store_->AddSamples(set, samples);
    response->set_stored(static_cast<uint32_t>(r.stored));
    response->set_set_total(r.set_total);
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::ListSamples(grpc::ServerContext*,
                                                 const v1::ListSamplesRequest* request,
                                                 v1::ListSamplesResponse* response) {
  if (!store_) return kNoStateDir;
  return Guard([&] {
    uint64_t total = 0;
    for (const auto& s : store_->SampleSets()) {
      if (!request->set().empty() && s.name != request->set()) continue;
      auto* out = response->add_sets();
      out->set_name(s.name);
      out->set_count(s.count);
      out->set_paths(s.paths);
      total += s.count;
    }
    response->set_total(total);
    if (request->include_samples()) {
      for (const auto& s : store_->Samples(request->set()))
        ToProto(s.stamp_ns, s.xa, s.xb, s.path, response->add_samples());
    }
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::DeleteSamples(grpc::ServerContext*,
                                                   const v1::DeleteSamplesRequest* request,
                                                   v1::DeleteSamplesResponse* response) {
  if (!store_) return kNoStateDir;
  if (request->set().empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "DeleteSamples needs the set to delete"};
  }
  return Guard([&] {
    response->set_deleted(store_->DeleteSamples(request->set()));
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::StartJob(grpc::ServerContext*,
                                              const v1::StartJobRequest* request, v1::Job* job) {
  if (!runner_) return kNoStateDir;
  return Guard([&] {
    *job = runner_->Submit(request->spec(), request->activate_on_success());
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::GetJob(grpc::ServerContext*, const v1::GetJobRequest* request,
                                            v1::Job* job) {
  if (!runner_) return kNoStateDir;
  if (request->id().empty()) return {grpc::StatusCode::INVALID_ARGUMENT, "GetJob needs a job id"};
  return Guard([&] {
    auto found = runner_->Get(request->id());
    if (!found) return grpc::Status(grpc::StatusCode::NOT_FOUND, "no job '" + request->id() + "'");
    *job = std::move(*found);
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::ListJobs(grpc::ServerContext*,
                                              const v1::ListJobsRequest* request,
                                              v1::ListJobsResponse* response) {
  if (!runner_) return kNoStateDir;
  const uint32_t limit = request->limit() == 0 ? kDefaultJobLimit : request->limit();
  if (limit > kMaxJobLimit) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "limit must be at most " + std::to_string(kMaxJobLimit)};
  }
  return Guard([&] {
    for (auto& j : runner_->List(limit)) *response->add_jobs() = std::move(j);
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::CancelJob(grpc::ServerContext*,
                                               const v1::CancelJobRequest* request, v1::Job* job) {
  if (!runner_) return kNoStateDir;
  if (request->id().empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "CancelJob needs a job id"};
  }
  return Guard([&] {
    *job = runner_->Cancel(request->id());
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::WatchJob(grpc::ServerContext* context,
                                              const v1::WatchJobRequest* request,
                                              grpc::ServerWriter<v1::Job>* writer) {
  if (!runner_) return kNoStateDir;
  if (request->id().empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "WatchJob needs a job id"};
  }
  return Guard([&] {
    // Synchronous writes: Write returns when the message is handed to the transport, so at
    // most one is in flight; a slow client sees fewer, newer updates rather than a backlog.
    uint64_t version = 0;
    uint64_t written = 0;
    v1::Job job;
    while (true) {
      if (!runner_->Watch(request->id(), &version, kWatchSlice, &job)) {
        return grpc::Status(grpc::StatusCode::NOT_FOUND, "no job '" + request->id() + "'");
      }
      if (version != written) {
        if (!writer->Write(job)) {
          return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
        }
        written = version;
      }
      if (IsFinished(job.state())) return grpc::Status::OK;
      if (context->IsCancelled()) {
        return grpc::Status(grpc::StatusCode::CANCELLED, "the client cancelled the watch");
      }
      if (shutting_down_.load()) {
        return grpc::Status(grpc::StatusCode::UNAVAILABLE, "epmapd is shutting down");
      }
    }
  });
}

grpc::Status CalibrationServiceImpl::ListModels(grpc::ServerContext*,
                                                const v1::ListModelsRequest* request,
                                                v1::ListModelsResponse* response) {
  if (!store_) return kNoStateDir;
  return Guard([&] {
    for (auto& m : store_->ListModels(request->kind())) *response->add_models() = std::move(m);
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::ActivateModel(grpc::ServerContext*,
                                                   const v1::ActivateModelRequest* request,
                                                   v1::Model* model) {
  if (!runner_) return kNoStateDir;
  if (request->id().empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "ActivateModel needs a model id"};
  }
  return Guard([&] {
    try {
      *model = runner_->Activate(request->id());
    } catch (const std::invalid_argument& e) {
      return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION, e.what());
    }
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::RollbackModel(grpc::ServerContext*,
                                                   const v1::RollbackModelRequest* request,
                                                   v1::Model* model) {
  if (!runner_) return kNoStateDir;
  const v1::JobKind kind = KindOrDefault(request->kind());
  if (kind != v1::EYE_HAND && kind != v1::STEREO_EXTRINSICS) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "unknown model kind"};
  }
  return Guard([&] {
    if (auto restored = runner_->Rollback(kind)) {
      *model = std::move(*restored);
    } else {
      model->set_kind(kind);  // empty id: no model of this kind is active now
    }
    return grpc::Status::OK;
  });
}

grpc::Status CalibrationServiceImpl::TransformPoints(grpc::ServerContext*,
                                                     const v1::TransformPointsRequest* request,
                                                     v1::TransformPointsResponse* response) {
  if (!store_) return kNoStateDir;
  for (int i = 0; i < request->points_size(); ++i) {
    const auto& p = request->points(i);
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) {
      return {grpc::StatusCode::INVALID_ARGUMENT,
              "point " + std::to_string(i) + " has a non-finite coordinate"};
    }
  }
  return Guard([&] {
    std::shared_ptr<const ActiveModels::EyeHand> model;
    if (request->model_id().empty()) {
      model = active_.eye_hand();
      if (!model) {
        return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                            "no eye-hand model is active: activate one (ActivateModel, "
                            "`epmapctl calib activate ID`) or name one in model_id");
      }
    } else {
      const auto stored = store_->GetModel(request->model_id());
      if (!stored) {
        return grpc::Status(grpc::StatusCode::NOT_FOUND, "no model '" + request->model_id() + "'");
      }
      if (stored->kind() != v1::EYE_HAND) {
        return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                            request->model_id() + " is not an eye-hand model");
      }
      ActiveModels scratch;
      InstallActiveModel(*stored, scratch);
      model = scratch.eye_hand();
    }
    for (const auto& p : request->points()) {
      ToProto(model->model.Apply(Eigen::Vector3d(p.x(), p.y(), p.z())), response->add_points());
    }
    response->set_model_id(model->id);
    return grpc::Status::OK;
  });
}

}  // namespace epmap::mapping
