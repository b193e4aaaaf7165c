// JobRunner with eye-hand jobs: real fits on the sim's eye-hand scenario, failures with
// actionable reasons and no model, cancellation, shutdown, watching, activation.

#include <gtest/gtest.h>

#include "clients/sim/scenario.h"
#include "services/mapping/calibration/job_runner.h"
#include "tests/support/test_env.h"

namespace epmap::mapping {
namespace {

using calibration::EyeHandSample;

std::vector<EyeHandSample> SimSamples(uint64_t seed = 1) {
  const auto scenario = sim::MakeScenario({.name = "eye-hand", .seed = seed});
  std::vector<EyeHandSample> out;
  for (const auto& s : scenario->EyeHandSamples()) {
    out.push_back({s.stamp_ns, s.xa, s.xb, s.path});
  }
  return out;
}

v1::JobSpec EyeHand(v1::EyeHandMethod method, uint32_t experts = 0, const std::string& set = "") {
  v1::JobSpec spec;
  spec.mutable_eye_hand()->set_method(method);
  spec.mutable_eye_hand()->set_experts(experts);
  spec.mutable_eye_hand()->set_set(set);
  return spec;
}

class JobRunnerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::FreshTempDir("calib-runner");
    store_ = std::make_unique<CalibrationStore>(dir_);
    runner_ = std::make_unique<JobRunner>(*store_, active_, StereoJobEnvironment{}, 1);
  }
  void TearDown() override {
    runner_.reset();
    store_.reset();
    std::filesystem::remove_all(dir_);
  }

  // Follows the job through Watch until it ends (or the time runs out).
  v1::Job WaitFinished(const std::string& id,
                       std::chrono::seconds timeout = std::chrono::seconds(60)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    uint64_t version = 0;
    v1::Job job;
    while (std::chrono::steady_clock::now() < deadline) {
      EXPECT_TRUE(runner_->Watch(id, &version, std::chrono::milliseconds(200), &job));
      if (IsFinished(job.state())) return job;
    }
    ADD_FAILURE() << id << " did not finish";
    return job;
  }

  std::filesystem::path dir_;
  ActiveModels active_;
  std::unique_ptr<CalibrationStore> store_;
  std::unique_ptr<JobRunner> runner_;
};

TEST_F(JobRunnerTest, MixtureJobYieldsAVersionedModelWithHoldoutErrors) {
  store_->AddSamples("default", SimSamples());
  const auto queued = runner_->Submit(EyeHand(v1::MIXTURE, 4), false);
  EXPECT_EQ(queued.state(), v1::QUEUED);
  EXPECT_EQ(queued.spec().eye_hand().set(), "default");  // defaults made explicit
  EXPECT_DOUBLE_EQ(queued.spec().eye_hand().holdout_share(), 0.25);
  const auto job = WaitFinished(queued.id());
  ASSERT_EQ(job.state(), v1::SUCCEEDED) << job.message();
  EXPECT_EQ(job.model_id(), "eye-hand-1");
  const auto& e = job.errors();
  EXPECT_EQ(e.experts(), 4u);
  EXPECT_EQ(e.holdout_count(), 500u);  // 5 of the 20 paths
  EXPECT_EQ(e.train_count(), 1500u);
  // The paper's mixture: well under the uncalibrated error and under 1.1 cm on unseen paths.
  EXPECT_LT(e.holdout_mean_m(), 0.011);
  EXPECT_LT(e.holdout_mean_m(), 0.3 * e.initial_mean_m());
  EXPECT_GT(job.started_ns(), 0);
  EXPECT_GE(job.finished_ns(), job.started_ns());
  // Not activated unless asked.
  EXPECT_FALSE(active_.eye_hand());
  EXPECT_FALSE(store_->ActiveModel(v1::EYE_HAND));
  const auto model = store_->GetModel("eye-hand-1");
  ASSERT_TRUE(model);
  EXPECT_EQ(model->job_id(), job.id());
  EXPECT_NE(model->description().find("mixture of 4"), std::string::npos);
  // The stored parameters are the model: they reproduce the hold-out error.
  const auto fitted = calibration::EyeHandModel::FromJson(model->parameters_json());
  EXPECT_EQ(fitted.experts().size(), 4u);
}

TEST_F(JobRunnerTest, ActivateOnSuccessPutsTheModelInForce) {
  const auto samples = SimSamples();
  store_->AddSamples("s", samples);
  const auto job = WaitFinished(runner_->Submit(EyeHand(v1::SE3, 0, "s"), true).id());
  ASSERT_EQ(job.state(), v1::SUCCEEDED) << job.message();
  ASSERT_EQ(active_.eye_hand_id(), job.model_id());
  EXPECT_EQ(store_->ActiveModel(v1::EYE_HAND)->id(), job.model_id());
  // CorrectVisionPoint applies f(X_A): on a sample it lands near X_B, far from X_A.
  const auto& s = samples[123];
  const Eigen::Vector3d corrected = active_.CorrectVisionPoint(s.xa);
  EXPECT_LT((corrected - s.xb).norm(), 0.5 * (s.xa - s.xb).norm());
  EXPECT_EQ(corrected, active_.eye_hand()->model.Apply(s.xa));
  // A second model, then activation and rollback through the runner keep memory and store equal.
  const auto second = WaitFinished(runner_->Submit(EyeHand(v1::SE3_SCALE, 0, "s"), false).id());
  ASSERT_EQ(second.state(), v1::SUCCEEDED) << second.message();
  runner_->Activate(second.model_id());
  EXPECT_EQ(active_.eye_hand_id(), second.model_id());
  const auto restored = runner_->Rollback(v1::EYE_HAND);
  ASSERT_TRUE(restored);
  EXPECT_EQ(restored->id(), job.model_id());
  EXPECT_EQ(active_.eye_hand_id(), job.model_id());
  EXPECT_FALSE(runner_->Rollback(v1::EYE_HAND));
  EXPECT_FALSE(active_.eye_hand());
  EXPECT_EQ(active_.CorrectVisionPoint(s.xa), s.xa);  // no model: unchanged
  EXPECT_THROW(runner_->Activate("eye-hand-42"), StoreError);
}

TEST_F(JobRunnerTest, BadDataFailsWithAReasonAndYieldsNoModel) {
  // On a line: the rotation about the line is unobservable.
  std::vector<EyeHandSample> line;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d x(0.2 + 0.004 * i, -0.1, -0.2);
    line.push_back({i, x, x + Eigen::Vector3d(0.01, 0, 0), i < 25 ? "a" : "b"});
  }
  store_->AddSamples("line", line);
  // Two samples only.
  store_->AddSamples("two", {line[0], line[30]});
  // On a plane: fine for SE(3), refused for se3-scale (the scale along the normal is free).
  std::vector<EyeHandSample> plane;
  for (int i = 0; i < 60; ++i) {
    const Eigen::Vector3d x(0.2 + 0.01 * (i % 10), -0.1 + 0.01 * (i / 10), -0.2);
    plane.push_back({i, x, x + Eigen::Vector3d(0.01, 0.002, 0), i < 30 ? "a" : "b"});
  }
  store_->AddSamples("plane", plane);
  const auto sim = SimSamples();
  store_->AddSamples("one-path", calibration::SelectPaths(sim, {"e00"}, true));

  struct Case {
    v1::JobSpec spec;
    std::string reason;  // a part of the message
  };
  auto with_holdout = EyeHand(v1::SE3, 0, "one-path");
  with_holdout.mutable_eye_hand()->add_holdout_paths("e07");
  const std::vector<Case> cases = {
      {EyeHand(v1::SE3, 0, "line"), "line"},
      {EyeHand(v1::SE3, 0, "two"), "at least 3"},
      {EyeHand(v1::SE3_SCALE, 0, "plane"), "plane"},
      {EyeHand(v1::MIXTURE, 40, "one-path"), "experts need at least"},
      {EyeHand(v1::SE3, 0, "missing"), "holds no samples"},
      {with_holdout, "'e07' is not in set"},
  };
  for (const auto& c : cases) {
    const auto job = WaitFinished(runner_->Submit(c.spec, /*activate_on_success=*/true).id());
    EXPECT_EQ(job.state(), v1::FAILED) << c.spec.ShortDebugString();
    EXPECT_NE(job.message().find(c.reason), std::string::npos)
        << "expected '" << c.reason << "' in: " << job.message();
    EXPECT_TRUE(job.model_id().empty());
  }
  EXPECT_TRUE(store_->ListModels(v1::JOB_KIND_UNSPECIFIED).empty());
  EXPECT_FALSE(active_.eye_hand());
  // The plane is fine for a rigid transform.
  const auto rigid = WaitFinished(runner_->Submit(EyeHand(v1::SE3, 0, "plane"), false).id());
  EXPECT_EQ(rigid.state(), v1::SUCCEEDED) << rigid.message();
}

TEST_F(JobRunnerTest, InvalidSpecsAreRefusedAtSubmit) {
  EXPECT_THROW(runner_->Submit(v1::JobSpec{}, false), std::invalid_argument);
  EXPECT_THROW(runner_->Submit(EyeHand(v1::EYE_HAND_METHOD_UNSPECIFIED), false),
               std::invalid_argument);
  EXPECT_THROW(runner_->Submit(EyeHand(v1::SE3, 4), false), std::invalid_argument);
  auto share = EyeHand(v1::SE3);
  share.mutable_eye_hand()->set_holdout_share(1.5);
  EXPECT_THROW(runner_->Submit(share, false), std::invalid_argument);
  v1::JobSpec stereo;
  stereo.mutable_stereo_extrinsics()->set_frames(100000);
  EXPECT_THROW(runner_->Submit(stereo, false), std::invalid_argument);
  EXPECT_TRUE(store_->ListJobs(10).empty());  // nothing recorded
}

TEST_F(JobRunnerTest, CancelStopsQueuedAndRunningJobsWithoutAModel) {
  // A long job: K chosen by cross-validation on 20 000 samples (20 paths of 1000).
  std::vector<EyeHandSample> many;
  for (uint64_t seed = 1; seed <= 10; ++seed) {
    const auto s = SimSamples(seed);
    many.insert(many.end(), s.begin(), s.end());
  }
  store_->AddSamples("many", many);
  const auto running = runner_->Submit(EyeHand(v1::MIXTURE, 0, "many"), true);
  const auto queued = runner_->Submit(EyeHand(v1::SE3, 0, "many"), true);
  // Wait until the long job is fitting.
  uint64_t version = 0;
  v1::Job seen;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline &&
         !(seen.state() == v1::RUNNING && seen.iteration() > 0)) {
    ASSERT_TRUE(runner_->Watch(running.id(), &version, std::chrono::milliseconds(100), &seen));
    ASSERT_FALSE(IsFinished(seen.state())) << "the job ended before it could be cancelled";
  }
  // The queued one ends at once.
  const auto cancelled_queued = runner_->Cancel(queued.id());
  EXPECT_EQ(cancelled_queued.state(), v1::CANCELLED);
  EXPECT_EQ(store_->GetJob(queued.id())->state(), v1::CANCELLED);
  // The running one at its next progress report.
  const auto t0 = std::chrono::steady_clock::now();
  runner_->Cancel(running.id());
  const auto job = WaitFinished(running.id());
  EXPECT_EQ(job.state(), v1::CANCELLED) << job.message();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(2));
  EXPECT_TRUE(store_->ListModels(v1::JOB_KIND_UNSPECIFIED).empty());
  EXPECT_FALSE(active_.eye_hand());
  EXPECT_THROW(runner_->Cancel("job-77"), StoreError);
  // Cancelling a finished job changes nothing.
  EXPECT_EQ(runner_->Cancel(running.id()).state(), v1::CANCELLED);
}

TEST_F(JobRunnerTest, StoppingTheServiceInterruptsItsJobs) {
  // A stereo job with no frames waits (RUNNING) until the service stops.
  StereoJobEnvironment env;
  RawFrameTap tap;
  CounterSet rejected;
  SensorState sensors(rejected);
  const auto scenario = sim::MakeScenario({.name = "vergence", .frames = 1});
  const auto chain = kinematics::UrdfChain::FromString(scenario->urdf());
  env.tap = &tap;
  env.sensors = &sensors;
  env.chain = &chain;
  runner_ = std::make_unique<JobRunner>(*store_, active_, env, 1);
  v1::JobSpec spec;
  spec.mutable_stereo_extrinsics()->set_frame_timeout_ms(60000);
  const auto job = runner_->Submit(spec, false);
  const auto queued = runner_->Submit(EyeHand(v1::SE3), false);
  uint64_t version = 0;
  v1::Job seen;
  while (seen.stage() != "waiting for frames") {
    ASSERT_TRUE(runner_->Watch(job.id(), &version, std::chrono::milliseconds(100), &seen));
    ASSERT_FALSE(IsFinished(seen.state())) << seen.message();
  }
  EXPECT_EQ(seen.state(), v1::RUNNING);
  runner_->Stop();
  EXPECT_EQ(store_->GetJob(job.id())->state(), v1::INTERRUPTED);
  EXPECT_EQ(store_->GetJob(queued.id())->state(), v1::INTERRUPTED);
  EXPECT_EQ(store_->InterruptUnfinishedJobs(0), 0);  // nothing left unfinished
  EXPECT_THROW(runner_->Submit(EyeHand(v1::SE3), false), StoreError);
}

TEST_F(JobRunnerTest, WatchReportsProgressAndTheEnd) {
  store_->AddSamples("default", SimSamples());
  const auto id = runner_->Submit(EyeHand(v1::MIXTURE, 0), false).id();  // K by CV
  uint64_t version = 0;
  v1::Job job;
  std::vector<v1::JobState> states;
  double last_progress = -1;
  bool progress_monotonic = true;
  while (true) {
    ASSERT_TRUE(runner_->Watch(id, &version, std::chrono::seconds(5), &job));
    if (states.empty() || states.back() != job.state()) states.push_back(job.state());
    progress_monotonic &= job.progress() >= last_progress;
    last_progress = job.progress();
    if (IsFinished(job.state())) break;
  }
  EXPECT_EQ(job.state(), v1::SUCCEEDED) << job.message();
  EXPECT_EQ(states.back(), v1::SUCCEEDED);
  EXPECT_TRUE(progress_monotonic);
  EXPECT_DOUBLE_EQ(job.progress(), 1.0);
  EXPECT_GE(job.errors().experts(), 1u);
  // A finished job answers at once, and an unknown one is not found.
  uint64_t again = 0;
  EXPECT_TRUE(runner_->Watch(id, &again, std::chrono::seconds(10), &job));
  EXPECT_EQ(job.state(), v1::SUCCEEDED);
  EXPECT_FALSE(runner_->Watch("job-404", &again, std::chrono::milliseconds(10), &job));
}

}  // namespace
}  // namespace epmap::mapping
