#pragma once
// epmap.v1.CalibrationService: samples, jobs and models over gRPC. Every handler only checks
// its arguments and talks to the store or the job runner; jobs run on the runner's threads.
// Without a state folder every call answers FAILED_PRECONDITION; unknown ids NOT_FOUND; bad
// arguments INVALID_ARGUMENT with the reason.

#include <epmap/v1/calibration_service.grpc.pb.h>

#include <atomic>

#include "services/mapping/calibration/active_models.h"
#include "services/mapping/calibration/calibration_store.h"
#include "services/mapping/calibration/job_runner.h"

namespace epmap::mapping {

class CalibrationServiceImpl final : public v1::CalibrationService::Service {
 public:
  // store and runner are null when no state folder is configured.
  CalibrationServiceImpl(CalibrationStore* store, JobRunner* runner, const ActiveModels& active,
                         const std::atomic<bool>& shutting_down)
      : store_(store), runner_(runner), active_(active), shutting_down_(shutting_down) {}

  grpc::Status AddSamples(grpc::ServerContext*, const v1::AddSamplesRequest*,
                          v1::AddSamplesResponse*) override;
  grpc::Status ListSamples(grpc::ServerContext*, const v1::ListSamplesRequest*,
                           v1::ListSamplesResponse*) override;
  grpc::Status DeleteSamples(grpc::ServerContext*, const v1::DeleteSamplesRequest*,
                             v1::DeleteSamplesResponse*) override;
  grpc::Status StartJob(grpc::ServerContext*, const v1::StartJobRequest*, v1::Job*) override;
  grpc::Status GetJob(grpc::ServerContext*, const v1::GetJobRequest*, v1::Job*) override;
  grpc::Status ListJobs(grpc::ServerContext*, const v1::ListJobsRequest*,
                        v1::ListJobsResponse*) override;
  grpc::Status CancelJob(grpc::ServerContext*, const v1::CancelJobRequest*, v1::Job*) override;
  grpc::Status WatchJob(grpc::ServerContext*, const v1::WatchJobRequest*,
                        grpc::ServerWriter<v1::Job>*) override;
  grpc::Status ListModels(grpc::ServerContext*, const v1::ListModelsRequest*,
                          v1::ListModelsResponse*) override;
  grpc::Status ActivateModel(grpc::ServerContext*, const v1::ActivateModelRequest*,
                             v1::Model*) override;
  grpc::Status RollbackModel(grpc::ServerContext*, const v1::RollbackModelRequest*,
                             v1::Model*) override;
  grpc::Status TransformPoints(grpc::ServerContext*, const v1::TransformPointsRequest*,
                               v1::TransformPointsResponse*) override;

 private:
  CalibrationStore* store_;
  JobRunner* runner_;
  const ActiveModels& active_;
  const std::atomic<bool>& shutting_down_;
};

// Checks samples as AddSamples and the DDS topic accept them: "" when every coordinate is
// finite, else the reason naming the first bad sample's index.
std::string CheckSamples(const std::vector<calibration::EyeHandSample>& samples);
// A sample set name: 1..128 printable characters.
std::string CheckSetName(const std::string& name);

}  // namespace epmap::mapping
