// Bad input to the CalibrationService of a real epmapd: clear statuses at once (INVALID_ARGUMENT,
// NOT_FOUND, FAILED_PRECONDITION) or a FAILED job with the reason; never a crash, never a model.
// Also WatchJob's stream and CancelJob over gRPC.

#include <gtest/gtest.h>

#include <cmath>

#include "tests/e2e/calibration/calibration_e2e.h"

namespace epmap::testing {
namespace {

void ExpectStatus(const grpc::Status& s, grpc::StatusCode code, const std::string& part) {
  EXPECT_EQ(s.error_code(), code) << s.error_message();
  EXPECT_NE(s.error_message().find(part), std::string::npos)
      << "expected '" << part << "' in: " << s.error_message();
}

TEST(CalibrationBadInput, WithoutAStateFolderEveryCallSaysSo) {
  const auto work = FreshTempDir("calib-nostate");
  Epmapd epmapd(UniqueDomainId(51), {}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();
  auto stub = CalibrationStub(epmapd.address());
  ExpectStatus(AddSamples(*stub, "", SimEyeHandSamples()), grpc::StatusCode::FAILED_PRECONDITION,
               "no --state-dir configured");
  v1::Job job;
  ExpectStatus(stub->StartJob(Deadline().get(), {}, &job), grpc::StatusCode::FAILED_PRECONDITION,
               "no --state-dir configured");
  v1::ListModelsResponse models;
  ExpectStatus(stub->ListModels(Deadline().get(), {}, &models),
               grpc::StatusCode::FAILED_PRECONDITION, "--state-dir");
  v1::ServiceStatus status;
  ASSERT_TRUE(epmapd.Status(&status).ok());  // the rest of the service is unaffected
  EXPECT_EQ(status.active_eye_hand_model(), "");
  std::filesystem::remove_all(work);
}

class CalibrationBadInputWithState : public ::testing::Test {
 protected:
  void SetUp() override {
    work_ = FreshTempDir("calib-bad");
    epmapd_ = std::make_unique<Epmapd>(
        UniqueDomainId(52),
        std::vector<std::string>{"--state-dir", work_ / "state", "--urdf",
                                 SourceDir() / "clients/sim/urdf/icub_head.urdf"},
        work_);
    ASSERT_TRUE(epmapd_->WaitReady()) << epmapd_->process().Output();
    stub_ = CalibrationStub(epmapd_->address());
  }
  void TearDown() override {
    EXPECT_TRUE(epmapd_->process().running()) << "epmapd died:\n" << epmapd_->process().Output();
    epmapd_.reset();
    std::filesystem::remove_all(work_);
  }
  v1::Job Start(const v1::JobSpec& spec, grpc::Status* status = nullptr) {
    v1::StartJobRequest request;
    *request.mutable_spec() = spec;
    v1::Job job;
    const auto s = stub_->StartJob(Deadline().get(), request, &job);
    if (status) *status = s;
    return job;
  }

  std::filesystem::path work_;
  std::unique_ptr<Epmapd> epmapd_;
  std::unique_ptr<v1::CalibrationService::Stub> stub_;
};

TEST_F(CalibrationBadInputWithState, SamplesAreCheckedBeforeAnyIsStored) {
  auto samples = SimEyeHandSamples();
  samples.resize(5);
  samples[3].mutable_xb()->set_y(std::nan(""));
  ExpectStatus(AddSamples(*stub_, "s", samples), grpc::StatusCode::INVALID_ARGUMENT, "sample 3");
  samples[3].mutable_xb()->set_y(INFINITY);
  ExpectStatus(AddSamples(*stub_, "s", samples), grpc::StatusCode::INVALID_ARGUMENT, "sample 3");
  samples[3].clear_xa();
  ExpectStatus(AddSamples(*stub_, "s", samples), grpc::StatusCode::INVALID_ARGUMENT,
               "sample 3 lacks xa");
  ExpectStatus(AddSamples(*stub_, "s", {}), grpc::StatusCode::INVALID_ARGUMENT, "at least one");
  ExpectStatus(AddSamples(*stub_, std::string(200, 'x'), {SimEyeHandSamples()[0]}),
               grpc::StatusCode::INVALID_ARGUMENT, "set name");
  v1::ListSamplesResponse listed;
  ASSERT_TRUE(stub_->ListSamples(Deadline().get(), {}, &listed).ok());
  EXPECT_EQ(listed.total(), 0u);  // nothing of the refused requests was stored
  v1::DeleteSamplesResponse deleted;
  ExpectStatus(stub_->DeleteSamples(Deadline().get(), {}, &deleted),
               grpc::StatusCode::INVALID_ARGUMENT, "set");
}

TEST_F(CalibrationBadInputWithState, UnknownIdsAreNotFoundAndBadSpecsInvalid) {
  v1::Job job;
  v1::GetJobRequest get;
  get.set_id("job-404");
  ExpectStatus(stub_->GetJob(Deadline().get(), get, &job), grpc::StatusCode::NOT_FOUND, "job-404");
  v1::CancelJobRequest cancel;
  cancel.set_id("job-404");
  ExpectStatus(stub_->CancelJob(Deadline().get(), cancel, &job), grpc::StatusCode::NOT_FOUND,
               "job-404");
  v1::WatchJobRequest watch;
  watch.set_id("job-404");
  auto context = Deadline();
  auto reader = stub_->WatchJob(context.get(), watch);
  EXPECT_FALSE(reader->Read(&job));
  ExpectStatus(reader->Finish(), grpc::StatusCode::NOT_FOUND, "job-404");
  v1::ActivateModelRequest activate;
  activate.set_id("eye-hand-9");
  v1::Model model;
  ExpectStatus(stub_->ActivateModel(Deadline().get(), activate, &model),
               grpc::StatusCode::NOT_FOUND, "eye-hand-9");
  v1::TransformPointsRequest transform;
  transform.set_model_id("eye-hand-9");
  v1::TransformPointsResponse moved;
  ExpectStatus(stub_->TransformPoints(Deadline().get(), transform, &moved),
               grpc::StatusCode::NOT_FOUND, "eye-hand-9");

  grpc::Status status;
  Start(v1::JobSpec{}, &status);
  ExpectStatus(status, grpc::StatusCode::INVALID_ARGUMENT, "eye_hand or stereo_extrinsics");
  v1::JobSpec spec;
  spec.mutable_eye_hand();
  Start(spec, &status);
  ExpectStatus(status, grpc::StatusCode::INVALID_ARGUMENT, "method");
  spec.mutable_eye_hand()->set_method(v1::SE3);
  spec.mutable_eye_hand()->set_experts(4);
  Start(spec, &status);
  ExpectStatus(status, grpc::StatusCode::INVALID_ARGUMENT, "MIXTURE only");
}

TEST_F(CalibrationBadInputWithState, DataTheFitCannotUseFailsTheJobWithoutAModel) {
  auto samples = SimEyeHandSamples();
  samples.resize(100);  // one path
  ASSERT_TRUE(AddSamples(*stub_, "one-path", samples).ok());
  v1::JobSpec spec;
  spec.mutable_eye_hand()->set_method(v1::MIXTURE);
  spec.mutable_eye_hand()->set_experts(10);  // 10 experts x 12 samples > 100
  spec.mutable_eye_hand()->set_set("one-path");
  auto job = Start(spec);
  job = WaitJob(
      *stub_, job.id(), [](const v1::Job& j) { return Finished(j.state()); },
      std::chrono::seconds(30));
  EXPECT_EQ(job.state(), v1::FAILED);
  EXPECT_NE(job.message().find("use fewer experts or collect more samples"), std::string::npos)
      << job.message();
  v1::TransformPointsRequest transform;
  transform.add_points()->set_x(std::nan(""));
  v1::TransformPointsResponse moved;
  ExpectStatus(stub_->TransformPoints(Deadline().get(), transform, &moved),
               grpc::StatusCode::INVALID_ARGUMENT, "point 0");
  v1::ListModelsResponse models;
  ASSERT_TRUE(stub_->ListModels(Deadline().get(), {}, &models).ok());
  EXPECT_EQ(models.models_size(), 0);
}

TEST_F(CalibrationBadInputWithState, WatchStreamsUntilTheEndAndCancelStopsAJob) {
  ASSERT_TRUE(AddSamples(*stub_, "default", SimEyeHandSamples()).ok());
  v1::JobSpec spec;
  spec.mutable_eye_hand()->set_method(v1::MIXTURE);  // K by cross-validation
  auto job = Start(spec);
  v1::WatchJobRequest watch;
  watch.set_id(job.id());
  grpc::ClientContext context;
  auto reader = stub_->WatchJob(&context, watch);
  std::vector<v1::Job> updates;
  while (reader->Read(&job)) updates.push_back(job);
  ASSERT_TRUE(reader->Finish().ok());
  ASSERT_FALSE(updates.empty());
  EXPECT_EQ(updates.back().state(), v1::SUCCEEDED) << updates.back().message();
  for (size_t i = 0; i + 1 < updates.size(); ++i) {
    EXPECT_FALSE(Finished(updates[i].state()));  // only the last message is the end
    EXPECT_LE(updates[i].progress(), updates[i + 1].progress());
  }
  // A stereo job waiting for frames (nobody publishes) is cancelled; its watch ends CANCELLED.
  v1::JobSpec stereo;
  stereo.mutable_stereo_extrinsics()->set_frame_timeout_ms(60000);
  job = Start(stereo);
  watch.set_id(job.id());
  grpc::ClientContext stereo_context;
  auto stereo_reader = stub_->WatchJob(&stereo_context, watch);
  ASSERT_TRUE(stereo_reader->Read(&job));
  v1::CancelJobRequest cancel;
  cancel.set_id(job.id());
  v1::Job cancelled;
  ASSERT_TRUE(stub_->CancelJob(Deadline().get(), cancel, &cancelled).ok());
  while (stereo_reader->Read(&job)) {
  }
  ASSERT_TRUE(stereo_reader->Finish().ok());
  EXPECT_EQ(job.state(), v1::CANCELLED);
  // A client that stops watching does not disturb the job.
  job = Start(stereo);
  watch.set_id(job.id());
  {
    grpc::ClientContext early;
    auto r = stub_->WatchJob(&early, watch);
    ASSERT_TRUE(r->Read(&job));
    early.TryCancel();
  }
  v1::GetJobRequest get;
  get.set_id(job.id());
  ASSERT_TRUE(stub_->GetJob(Deadline().get(), get, &job).ok());
  EXPECT_FALSE(Finished(job.state()));
  cancel.set_id(job.id());
  ASSERT_TRUE(stub_->CancelJob(Deadline().get(), cancel, &cancelled).ok());
}

}  // namespace
}  // namespace epmap::testing
