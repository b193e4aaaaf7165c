// CalibrationStore: samples, jobs, models, activation and rollback, and what survives reopening
// the database (the process's view after a restart).

#include <gtest/gtest.h>

#include "services/mapping/calibration/calibration_store.h"
#include "tests/support/test_env.h"

namespace epmap::mapping {
namespace {

using calibration::EyeHandSample;

std::vector<EyeHandSample> Samples(int n, const std::string& path, double offset = 0) {
  std::vector<EyeHandSample> out;
  for (int i = 0; i < n; ++i) {
    EyeHandSample s;
    s.stamp_ns = 1000 + i;
    s.xa = Eigen::Vector3d(0.1 * i + offset, 0.2, -0.3);
    s.xb = Eigen::Vector3d(0.1 * i + offset, 0.25, -0.3);
    s.path = path;
    out.push_back(s);
  }
  return out;
}

v1::Model ModelOf(v1::JobKind kind, const std::string& parameters = "{}") {
  v1::Model m;
  m.set_kind(kind);
  m.set_description("test");
  m.set_parameters_json(parameters);
  m.mutable_errors()->set_holdout_mean_m(0.01);
  return m;
}

class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = testing::FreshTempDir("calib-store"); }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // A finished job with a model of `kind`; returns the model id.
  std::string AddModel(CalibrationStore& store, v1::JobKind kind, bool activate = false) {
    v1::JobSpec spec;
    auto job = store.CreateJob(kind, spec, activate, 1);
    return store.FinishJobWithModel(job, ModelOf(kind), activate, 2).id();
  }

  std::filesystem::path dir_;
};

TEST_F(StoreTest, SamplesAreStoredBySetInOrderAndSurviveReopening) {
  {
    CalibrationStore store(dir_);
    const auto r1 = store.AddSamples("a", Samples(3, "p1"));
    EXPECT_EQ(r1.stored, 3u);
    EXPECT_EQ(r1.set_total, 3u);
    const auto r2 = store.AddSamples("a", Samples(2, "p2", 10));
    EXPECT_EQ(r2.set_total, 5u);
    store.AddSamples("b", Samples(4, "q"));
  }
  CalibrationStore store(dir_);
  const auto a = store.Samples("a");
  ASSERT_EQ(a.size(), 5u);
  EXPECT_EQ(a[0].path, "p1");
  EXPECT_EQ(a[3].path, "p2");
  EXPECT_DOUBLE_EQ(a[4].xa.x(), 10.1);  // bit-exact doubles through SQLite REAL
  EXPECT_EQ(a[4].stamp_ns, 1001);
  EXPECT_EQ(store.Samples("").size(), 9u);
  const auto sets = store.SampleSets();
  ASSERT_EQ(sets.size(), 2u);
  EXPECT_EQ(sets[0].name, "a");
  EXPECT_EQ(sets[0].count, 5u);
  EXPECT_EQ(sets[0].paths, 2u);
  EXPECT_EQ(store.DeleteSamples("a"), 5u);
  EXPECT_TRUE(store.Samples("a").empty());
  EXPECT_EQ(store.DeleteSamples("nothing"), 0u);
}

TEST_F(StoreTest, ASecondProcessCannotOpenTheSameFolder) {
  CalibrationStore store(dir_);
  try {
    CalibrationStore second(dir_);
    FAIL() << "a second store on the same folder must be refused";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("in use"), std::string::npos) << e.what();
  }
}

TEST_F(StoreTest, JobsGetIdsInOrderAndUnfinishedOnesAreInterruptedAfterARestart) {
  {
    CalibrationStore store(dir_);
    v1::JobSpec spec;
    spec.mutable_eye_hand()->set_method(v1::MIXTURE);
    spec.mutable_eye_hand()->set_experts(4);
    auto queued = store.CreateJob(v1::EYE_HAND, spec, false, 10);
    auto running = store.CreateJob(v1::EYE_HAND, spec, true, 11);
    auto failed = store.CreateJob(v1::STEREO_EXTRINSICS, {}, false, 12);
    EXPECT_EQ(queued.id(), "job-1");
    EXPECT_EQ(running.id(), "job-2");
    EXPECT_EQ(failed.id(), "job-3");
    running.set_state(v1::RUNNING);
    running.set_started_ns(20);
    store.UpdateJob(running);
    failed.set_state(v1::FAILED);
    failed.set_message("no frames");
    store.UpdateJob(failed);
    v1::Job unknown;
    unknown.set_id("job-99");
    EXPECT_THROW(store.UpdateJob(unknown), StoreError);
  }
  // The process died with job-1 queued and job-2 running.
  CalibrationStore store(dir_);
  EXPECT_EQ(store.InterruptUnfinishedJobs(100), 2);
  const auto jobs = store.ListJobs(10);
  ASSERT_EQ(jobs.size(), 3u);
  EXPECT_EQ(jobs[0].id(), "job-3");  // newest first
  EXPECT_EQ(jobs[0].state(), v1::FAILED);
  EXPECT_EQ(jobs[0].message(), "no frames");
  EXPECT_EQ(jobs[1].state(), v1::INTERRUPTED);
  EXPECT_NE(jobs[1].message().find("running"), std::string::npos) << jobs[1].message();
  EXPECT_EQ(jobs[1].started_ns(), 20);
  EXPECT_TRUE(jobs[1].activate_on_success());
  EXPECT_EQ(jobs[2].state(), v1::INTERRUPTED);
  EXPECT_NE(jobs[2].message().find("queued"), std::string::npos) << jobs[2].message();
  EXPECT_EQ(jobs[2].spec().eye_hand().experts(), 4u);  // the spec round-trips
  EXPECT_EQ(store.ListJobs(1).size(), 1u);
  EXPECT_FALSE(store.GetJob("job-4"));
  // New ids continue after the old ones.
  EXPECT_EQ(store.CreateJob(v1::EYE_HAND, {}, false, 200).id(), "job-4");
}

TEST_F(StoreTest, ModelsAreVersionedPerKindAndFinishTheirJob) {
  CalibrationStore store(dir_);
  v1::JobSpec spec;
  auto job = store.CreateJob(v1::EYE_HAND, spec, false, 1);
  job.set_message("done");
  const auto m1 = store.FinishJobWithModel(job, ModelOf(v1::EYE_HAND), false, 5);
  EXPECT_EQ(m1.id(), "eye-hand-1");
  EXPECT_EQ(m1.version(), 1u);
  EXPECT_EQ(m1.job_id(), job.id());
  EXPECT_FALSE(m1.active());
  EXPECT_EQ(job.state(), v1::SUCCEEDED);
  EXPECT_EQ(job.model_id(), "eye-hand-1");
  const auto stored_job = store.GetJob(job.id());
  ASSERT_TRUE(stored_job);
  EXPECT_EQ(stored_job->state(), v1::SUCCEEDED);
  EXPECT_EQ(stored_job->model_id(), "eye-hand-1");
  EXPECT_EQ(stored_job->message(), "done");

  EXPECT_EQ(AddModel(store, v1::STEREO_EXTRINSICS), "stereo-extrinsics-1");
  EXPECT_EQ(AddModel(store, v1::EYE_HAND, /*activate=*/true), "eye-hand-2");
  EXPECT_EQ(store.ListModels(v1::JOB_KIND_UNSPECIFIED).size(), 3u);
  const auto eye_hand = store.ListModels(v1::EYE_HAND);
  ASSERT_EQ(eye_hand.size(), 2u);
  EXPECT_FALSE(eye_hand[0].active());
  EXPECT_TRUE(eye_hand[1].active());
  EXPECT_DOUBLE_EQ(eye_hand[1].errors().holdout_mean_m(), 0.01);
  EXPECT_EQ(store.ActiveModel(v1::EYE_HAND)->id(), "eye-hand-2");
  EXPECT_FALSE(store.ActiveModel(v1::STEREO_EXTRINSICS));
  EXPECT_FALSE(store.GetModel("eye-hand-3"));
}

TEST_F(StoreTest, RollbackWalksBackTheActivationsOfOneKind) {
  {
    CalibrationStore store(dir_);
    const auto a = AddModel(store, v1::EYE_HAND);
    const auto b = AddModel(store, v1::EYE_HAND);
    const auto c = AddModel(store, v1::EYE_HAND);
    const auto s = AddModel(store, v1::STEREO_EXTRINSICS);
    EXPECT_THROW(store.Rollback(v1::EYE_HAND, 1), StoreError);  // nothing active yet
    store.Activate(a, 1);
    store.Activate(b, 2);
    store.Activate(b, 3);  // already active: not a new activation
    store.Activate(s, 4);
    EXPECT_TRUE(store.Activate(c, 5).active());
    try {
      store.Activate("eye-hand-9", 6);
      FAIL();
    } catch (const StoreError& e) {
      EXPECT_EQ(e.code(), StoreError::Code::kNotFound);
    }
    const auto back = store.Rollback(v1::EYE_HAND, 7);
    ASSERT_TRUE(back);
    EXPECT_EQ(back->id(), b);
    EXPECT_TRUE(back->active());
    EXPECT_EQ(store.ActiveModel(v1::STEREO_EXTRINSICS)->id(), s);  // other kinds untouched
  }
  // The active model and the history survive a restart.
  CalibrationStore store(dir_);
  EXPECT_EQ(store.ActiveModel(v1::EYE_HAND)->id(), "eye-hand-2");
  EXPECT_EQ(store.Rollback(v1::EYE_HAND, 8)->id(), "eye-hand-1");
  EXPECT_FALSE(store.Rollback(v1::EYE_HAND, 9));  // the first activation undone: none active
  EXPECT_FALSE(store.ActiveModel(v1::EYE_HAND));
  try {
    store.Rollback(v1::EYE_HAND, 10);
    FAIL();
  } catch (const StoreError& e) {
    EXPECT_EQ(e.code(), StoreError::Code::kFailedPrecondition);
  }
}

}  // namespace
}  // namespace epmap::mapping
