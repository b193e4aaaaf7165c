// Durability with real processes: epmapd is killed with SIGKILL (no chance to flush anything)
// while clients add samples or a job runs, and restarted on the same state folder.

#include <gtest/gtest.h>

#include <atomic>
#include <set>
#include <thread>

#include "tests/e2e/calibration/calibration_e2e.h"

namespace epmap::testing {
namespace {

std::filesystem::path HeadUrdf() {
  return SourceDir() / "clients/sim/urdf/icub_head.urdf";
}

TEST(CalibrationDurability, EveryAcknowledgedSampleSurvivesKill9) {
  const auto work = FreshTempDir("calib-kill-samples");
  const std::vector<std::string> args = {"--state-dir", work / "state"};
  const auto samples = SimEyeHandSamples();
  std::atomic<int> acknowledged{0};
  {
    Epmapd epmapd(UniqueDomainId(41), args, work);
    ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();
    // A client adds batches of 50 samples, each under its own path label, as fast as it can;
    // the service is killed in the middle of that.
    std::thread client([&] {
      auto stub = CalibrationStub(epmapd.address());
      for (int b = 0; b < 1000; ++b) {
        std::vector<v1::EyeHandSample> batch(samples.begin() + (b % 40) * 50,
                                             samples.begin() + (b % 40 + 1) * 50);
        for (auto& s : batch) s.set_path("batch" + std::to_string(b));
        if (!AddSamples(*stub, "kill", batch).ok()) return;  // the service is gone
        acknowledged = b + 1;
      }
    });
    while (acknowledged < 20) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    epmapd.process().Signal(SIGKILL);
    client.join();
    ASSERT_EQ(epmapd.process().Wait(std::chrono::seconds(5)), 128 + SIGKILL);
  }
  const int acked = acknowledged.load();
  ASSERT_GE(acked, 20);
  std::printf("%d batches of 50 samples acknowledged before SIGKILL\n", acked);
  Epmapd restarted(UniqueDomainId(42), args, work);
  ASSERT_TRUE(restarted.WaitReady()) << restarted.process().Output();
  auto stub = CalibrationStub(restarted.address());
  v1::ListSamplesRequest request;
  request.set_set("kill");
  request.set_include_samples(true);
  v1::ListSamplesResponse listed;
  ASSERT_TRUE(stub->ListSamples(Deadline().get(), request, &listed).ok());
  std::set<std::string> paths;
  for (const auto& s : listed.samples()) paths.insert(s.path());
  for (int b = 0; b < acked; ++b) {
    EXPECT_TRUE(paths.count("batch" + std::to_string(b))) << "acknowledged batch " << b << " lost";
  }
  // At most the one batch in flight at the kill may have been stored without its reply.
  EXPECT_GE(listed.total(), 50u * static_cast<uint64_t>(acked));
  EXPECT_LE(listed.total(), 50u * static_cast<uint64_t>(acked + 1));
  EXPECT_EQ(listed.total() % 50, 0u) << "a batch was stored in part";
  std::filesystem::remove_all(work);
}

TEST(CalibrationDurability, AJobRunningAtACrashIsInterruptedAndTheActiveModelStays) {
  const auto work = FreshTempDir("calib-kill-job");
  const std::vector<std::string> args = {"--state-dir", work / "state", "--urdf", HeadUrdf()};
  std::string stereo_id, queued_id;
  {
    Epmapd epmapd(UniqueDomainId(43), args, work);
    ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();
    auto stub = CalibrationStub(epmapd.address());
    ASSERT_TRUE(AddSamples(*stub, "default", SimEyeHandSamples()).ok());
    // A model, activated by its job.
    v1::StartJobRequest start;
    start.mutable_spec()->mutable_eye_hand()->set_method(v1::SE3);
    start.set_activate_on_success(true);
    v1::Job job;
    ASSERT_TRUE(stub->StartJob(Deadline().get(), start, &job).ok());
    job = WaitJob(
        *stub, job.id(), [](const v1::Job& j) { return Finished(j.state()); },
        std::chrono::seconds(30));
    ASSERT_EQ(job.state(), v1::SUCCEEDED) << job.message();
    ASSERT_EQ(job.model_id(), "eye-hand-1");
    // A stereo job that waits for frames nobody sends (RUNNING), and a job queued behind it.
    v1::StartJobRequest stereo;
    stereo.mutable_spec()->mutable_stereo_extrinsics()->set_frame_timeout_ms(120000);
    ASSERT_TRUE(stub->StartJob(Deadline().get(), stereo, &job).ok());
    stereo_id = job.id();
    start.mutable_spec()->mutable_eye_hand()->set_method(v1::MIXTURE);
    ASSERT_TRUE(stub->StartJob(Deadline().get(), start, &job).ok());
    queued_id = job.id();
    // RUNNING is reported at "starting", a moment before the job reaches its wait for frames.
    job = WaitJob(
        *stub, stereo_id,
        [](const v1::Job& j) {
          return j.state() == v1::RUNNING && j.stage() == "waiting for frames";
        },
        std::chrono::seconds(10));
    ASSERT_EQ(job.state(), v1::RUNNING);
    EXPECT_EQ(job.stage(), "waiting for frames");
    epmapd.process().Signal(SIGKILL);
    ASSERT_EQ(epmapd.process().Wait(std::chrono::seconds(5)), 128 + SIGKILL);
  }
  Epmapd restarted(UniqueDomainId(44), args, work);
  ASSERT_TRUE(restarted.WaitReady()) << restarted.process().Output();
  auto stub = CalibrationStub(restarted.address());
  v1::GetJobRequest get;
  get.set_id(stereo_id);
  v1::Job job;
  ASSERT_TRUE(stub->GetJob(Deadline().get(), get, &job).ok());
  EXPECT_EQ(job.state(), v1::INTERRUPTED);
  EXPECT_NE(job.message().find("running"), std::string::npos) << job.message();
  get.set_id(queued_id);
  ASSERT_TRUE(stub->GetJob(Deadline().get(), get, &job).ok());
  EXPECT_EQ(job.state(), v1::INTERRUPTED);
  EXPECT_TRUE(job.model_id().empty());
  // The model active before the crash is still active, in the store and in the service.
  v1::ServiceStatus status;
  ASSERT_TRUE(restarted.Status(&status).ok());
  EXPECT_EQ(status.active_eye_hand_model(), "eye-hand-1");
  v1::ListModelsResponse models;
  ASSERT_TRUE(stub->ListModels(Deadline().get(), {}, &models).ok());
  ASSERT_EQ(models.models_size(), 1);
  EXPECT_TRUE(models.models(0).active());
  v1::TransformPointsRequest transform;
  auto* p = transform.add_points();
  p->set_x(0.3);
  p->set_y(-0.2);
  p->set_z(-0.2);
  v1::TransformPointsResponse moved;
  ASSERT_TRUE(stub->TransformPoints(Deadline().get(), transform, &moved).ok());
  EXPECT_EQ(moved.model_id(), "eye-hand-1");
  EXPECT_GT(std::abs(moved.points(0).x() - 0.3) + std::abs(moved.points(0).z() + 0.2), 1e-3);

  // A clean stop (SIGTERM) during a job: the job ends INTERRUPTED and epmapd exits 0.
  v1::StartJobRequest stereo;
  stereo.mutable_spec()->mutable_stereo_extrinsics()->set_frame_timeout_ms(120000);
  ASSERT_TRUE(stub->StartJob(Deadline().get(), stereo, &job).ok());
  const std::string last = job.id();
  job = WaitJob(
      *stub, last, [](const v1::Job& j) { return j.state() == v1::RUNNING; },
      std::chrono::seconds(10));
  ASSERT_EQ(job.state(), v1::RUNNING);
  restarted.process().Signal(SIGTERM);
  EXPECT_EQ(restarted.process().Wait(std::chrono::seconds(10)), 0) << restarted.process().Output();
  Epmapd third(UniqueDomainId(45), args, work);
  ASSERT_TRUE(third.WaitReady()) << third.process().Output();
  auto stub3 = CalibrationStub(third.address());
  get.set_id(last);
  ASSERT_TRUE(stub3->GetJob(Deadline().get(), get, &job).ok());
  EXPECT_EQ(job.state(), v1::INTERRUPTED);
  EXPECT_NE(job.message().find("stopped"), std::string::npos) << job.message();
  std::filesystem::remove_all(work);
}

}  // namespace
}  // namespace epmap::testing
