// The epmapctl calib contract against a real epmapd with a state folder:
// add-samples -> samples -> start mixture --wait --json -> models -> activate -> transform ->
// status -> rollback, plus the failing paths (exit code non-zero with the reason), and the
// eye-hand samples topic fed by epmap-sim publish --scenario eye-hand.

#include <gtest/gtest.h>

#include "perception/calibration/eye_hand_model.h"
#include "perception/calibration/eye_hand_samples.h"
#include "tests/e2e/calibration/calibration_e2e.h"

namespace epmap::testing {
namespace {

class CalibCli : public ::testing::Test {
 protected:
  void SetUp() override {
    work_ = FreshTempDir("calib-cli");
    epmapd_ = std::make_unique<Epmapd>(
        UniqueDomainId(31), std::vector<std::string>{"--state-dir", work_ / "state"}, work_);
    ASSERT_TRUE(epmapd_->WaitReady()) << epmapd_->process().Output();
  }
  void TearDown() override {
    epmapd_.reset();
    std::filesystem::remove_all(work_);
  }
  CliResult Ctl(std::vector<std::string> args) {
    args.insert(args.begin(), {"--server", epmapd_->address()});
    return RunBinary("epmapctl", args, work_);
  }

  std::filesystem::path work_;
  std::unique_ptr<Epmapd> epmapd_;
};

TEST_F(CalibCli, AddSamplesStartMixtureActivateTransformRollback) {
  // Samples as epmap-sim records them.
  const auto rec =
      RunBinary("epmap-sim", {"record", "--scenario", "eye-hand", "--out", work_ / "eh"}, work_);
  ASSERT_EQ(rec.exit_code, 0) << rec.err;
  const auto csv = work_ / "eh" / "mav0" / "samples.csv";

  auto r = Ctl({"calib", "add-samples", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("stored 2000 samples"), std::string::npos) << r.out;

  r = Ctl({"calib", "samples", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  v1::ListSamplesResponse listed;
  ASSERT_TRUE(ParseJson(r.LastLine(), &listed)) << r.out;
  EXPECT_EQ(listed.total(), 2000u);
  ASSERT_EQ(listed.sets_size(), 1);
  EXPECT_EQ(listed.sets(0).name(), "default");
  EXPECT_EQ(listed.sets(0).paths(), 20u);

  r = Ctl(
      {"calib", "start", "eye-hand", "--method", "mixture", "--experts", "4", "--wait", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  v1::Job job;
  ASSERT_TRUE(ParseJson(r.LastLine(), &job)) << r.out;
  EXPECT_EQ(job.state(), v1::SUCCEEDED);
  EXPECT_EQ(job.model_id(), "eye-hand-1");
  EXPECT_EQ(job.errors().experts(), 4u);
  EXPECT_GT(job.errors().holdout_count(), 0u);
  EXPECT_LT(job.errors().holdout_mean_m(), 0.011);  // paper 001: 1.1 cm
  // Progress as JSON lines on stderr (the job may be past RUNNING when the watch starts).
  EXPECT_NE(r.err.find("{\"id\":\"job-1\""), std::string::npos)
      << "progress lines expected on stderr: " << r.err;

  r = Ctl({"calib", "models", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  v1::ListModelsResponse models;
  ASSERT_TRUE(ParseJson(r.LastLine(), &models)) << r.out;
  ASSERT_EQ(models.models_size(), 1);
  EXPECT_EQ(models.models(0).id(), "eye-hand-1");
  EXPECT_FALSE(models.models(0).active());  // never activated implicitly
  const auto fitted = calibration::EyeHandModel::FromJson(models.models(0).parameters_json());

  r = Ctl({"calib", "activate", "eye-hand-1"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  v1::ServiceStatus status;
  ASSERT_TRUE(epmapd_->Status(&status).ok());
  EXPECT_EQ(status.active_eye_hand_model(), "eye-hand-1");

  // transform: a header line, then x,y,z per row (vision frame) -> corrected x,y,z.
  const auto samples = calibration::ReadEyeHandCsv(csv);
  {
    std::ofstream in(work_ / "in.csv");
    in << "x,y,z\n";
    for (size_t i = 0; i < samples.size(); i += 100) {
      in << samples[i].xa.x() << "," << samples[i].xa.y() << "," << samples[i].xa.z() << "\n";
    }
  }
  r = Ctl({"calib", "transform", "--in", work_ / "in.csv", "--out", work_ / "out.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(work_ / "in.csv"), out(work_ / "out.csv");
  std::string in_line, out_line;
  std::getline(in, in_line);
  std::getline(out, out_line);
  EXPECT_EQ(out_line, "x,y,z");
  int rows = 0;
  double corrected_error = 0, raw_error = 0;
  for (size_t i = 0; i < samples.size(); i += 100, ++rows) {
    ASSERT_TRUE(std::getline(in, in_line) && std::getline(out, out_line));
    double x, y, z, cx, cy, cz;
    ASSERT_EQ(std::sscanf(in_line.c_str(), "%lf,%lf,%lf", &x, &y, &z), 3);
    ASSERT_EQ(std::sscanf(out_line.c_str(), "%lf,%lf,%lf", &cx, &cy, &cz), 3) << out_line;
    const Eigen::Vector3d expected = fitted.Apply(Eigen::Vector3d(x, y, z));
    EXPECT_LT((expected - Eigen::Vector3d(cx, cy, cz)).norm(), 1e-6);
    corrected_error += (Eigen::Vector3d(cx, cy, cz) - samples[i].xb).norm();
    raw_error += (samples[i].xa - samples[i].xb).norm();
  }
  EXPECT_EQ(rows, 20);
  EXPECT_LT(corrected_error, 0.3 * raw_error);

  r = Ctl({"calib", "rollback"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(epmapd_->Status(&status).ok());
  EXPECT_EQ(status.active_eye_hand_model(), "");
  r = Ctl({"calib", "transform", "--in", work_ / "in.csv", "--out", work_ / "out2.csv"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("no eye-hand model is active"), std::string::npos) << r.err;
  r = Ctl({"calib", "rollback"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("FAILED_PRECONDITION"), std::string::npos) << r.err;

  r = Ctl({"calib", "jobs", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  v1::ListJobsResponse jobs;
  ASSERT_TRUE(ParseJson(r.LastLine(), &jobs)) << r.out;
  ASSERT_EQ(jobs.jobs_size(), 1);
  EXPECT_EQ(jobs.jobs(0).state(), v1::SUCCEEDED);
}

TEST_F(CalibCli, FailedJobsExitNonZeroWithTheReason) {
  // Samples on a line: the rotation about it is unobservable.
  {
    std::ofstream csv(work_ / "line.csv");
    csv << "#timestamp [ns],xa [m],ya [m],za [m],xb [m],yb [m],zb [m],path\n";
    for (int i = 0; i < 40; ++i) {
      csv << 1000 + i << "," << 0.2 + 0.005 * i << ",-0.1,-0.2," << 0.21 + 0.005 * i
          << ",-0.1,-0.2," << (i < 20 ? "a" : "b") << "\n";
    }
  }
  auto r = Ctl({"calib", "add-samples", work_ / "line.csv", "--set", "line"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = Ctl({"calib", "start", "eye-hand", "--method", "se3", "--set", "line", "--wait"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("FAILED"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("line"), std::string::npos) << r.err;
  r = Ctl({"calib", "start", "eye-hand", "--method", "se3", "--set", "line", "--wait", "--json"});
  EXPECT_EQ(r.exit_code, 1);
  v1::Job job;
  ASSERT_TRUE(ParseJson(r.LastLine(), &job)) << r.out;
  EXPECT_EQ(job.state(), v1::FAILED);
  EXPECT_TRUE(job.model_id().empty());
  // No URDF: the stereo job cannot have a kinematic prior.
  r = Ctl({"calib", "start", "stereo-extrinsics", "--frames", "3", "--wait"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--urdf"), std::string::npos) << r.err;
  // Nothing was yielded or activated.
  r = Ctl({"calib", "models"});
  EXPECT_NE(r.out.find("no models"), std::string::npos) << r.out;
  // A NaN in the file is refused before anything is sent, naming the line.
  {
    std::ofstream csv(work_ / "nan.csv");
    csv << "#timestamp [ns],xa,ya,za,xb,yb,zb,path\n1,0.1,0.2,0.3,0.1,0.2,0.3,a\n"
        << "2,nan,0.2,0.3,0.1,0.2,0.3,a\n";
  }
  r = Ctl({"calib", "add-samples", work_ / "nan.csv"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("nan.csv:3"), std::string::npos) << r.err;
  r = Ctl({"calib", "activate", "eye-hand-9"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("NOT_FOUND"), std::string::npos) << r.err;
}

TEST_F(CalibCli, EyeHandSamplesArriveOverDds) {
  const auto r = RunBinary("epmap-sim",
                           {"publish", "--scenario", "eye-hand", "--domain",
                            std::to_string(epmapd_->domain()), "--rate", "50"},
                           work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto stub = CalibrationStub(epmapd_->address());
  v1::ListSamplesResponse listed;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < deadline && listed.total() < 2000) {
    listed.Clear();
    ASSERT_TRUE(stub->ListSamples(Deadline().get(), {}, &listed).ok());
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_EQ(listed.sets_size(), 1);
  EXPECT_EQ(listed.sets(0).name(), "sim-eye-hand-seed1");
  EXPECT_EQ(listed.sets(0).count(), 2000u);  // one message per path, none lost
  EXPECT_EQ(listed.sets(0).paths(), 20u);
}

}  // namespace
}  // namespace epmap::testing
