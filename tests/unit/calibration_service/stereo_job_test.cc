// Stereo-extrinsics jobs through the JobRunner, on frames of the sim's vergence scenario offered
// to the raw-frame tap as the pipeline offers them, with CameraInfo and joint readings in the
// SensorState as DDS ingest leaves them. The eye encoders are biased (vergence +0.75 deg): the
// job must find that correction, and refuse featureless and planar scenes with a reason.

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "clients/sim/scenario.h"
#include "perception/calibration/stereo_self_calibration.h"
#include "services/mapping/calibration/job_runner.h"
#include "tests/support/test_env.h"
#include "tests/unit/calibration/synthetic_stereo.h"

namespace epmap::mapping {
namespace {

struct Frame {
  StereoFrame stereo;
  std::vector<double> joints;  // encoder readings (scenario order)
  Eigen::Isometry3d truth;     // true T_cam0_cam1
};

class StereoJobTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scenario_ = sim::MakeScenario({.name = "vergence"});
    chain_.emplace(kinematics::UrdfChain::FromString(scenario_->urdf()));
    sensors_.SetCameraInfo(0, camera::Pinhole(scenario_->cam0().pinhole()));
    sensors_.SetCameraInfo(1, camera::Pinhole(scenario_->cam1().pinhole()));
    dir_ = testing::FreshTempDir("calib-stereo");
    store_ = std::make_unique<CalibrationStore>(dir_);
  }
  void TearDown() override {
    StopFeeding();
    runner_.reset();
    store_.reset();
    std::filesystem::remove_all(dir_);
  }

  void StartRunner(const kinematics::UrdfChain* chain) {
    StereoJobEnvironment env;
    env.tap = &tap_;
    env.sensors = &sensors_;
    env.chain = chain;
    env.urdf_path = "icub_head.urdf";
    env.image_topics = "rt/stereo/left/image_raw, rt/stereo/right/image_raw";
    env.settings.stereo_frame_interval_ns = 0;
    env.settings.stereo_frame_timeout_ns = 5'000'000'000;
    runner_ = std::make_unique<JobRunner>(*store_, active_, env, 1);
  }

  Frame Render(int index) {
    const sim::SimFrame f = scenario_->RenderSensors(index);
    Frame out;
    out.stereo.sequence = static_cast<uint64_t>(index);
    out.stereo.stamp_ns = f.stamp_ns;
    out.stereo.left = f.left;
    out.stereo.right = f.right;
    out.joints = f.joints;
    out.truth = f.gt_T_cam0_cam1;
    return out;
  }

  // Offers the frames in a loop (joints first, as they arrive on their own topic), ~30 Hz.
  void Feed(std::vector<Frame> frames) {
    feeding_ = true;
    feeder_ = std::thread([this, frames = std::move(frames)] {
      int64_t shift = 0;
      while (feeding_) {
        for (const auto& f : frames) {
          if (!feeding_) return;
          StereoFrame s = f.stereo;
          s.stamp_ns += shift;  // stamps keep increasing round after round
          sensors_.AddJoints({s.stamp_ns, scenario_->joint_names(), f.joints});
          tap_.Offer(s);
          std::this_thread::sleep_for(std::chrono::milliseconds(30));
        }
        shift += 100'000'000'000;
      }
    });
  }
  void StopFeeding() {
    feeding_ = false;
    if (feeder_.joinable()) feeder_.join();
  }

  v1::Job Run(uint32_t frames, bool activate = false) {
    v1::JobSpec spec;
    spec.mutable_stereo_extrinsics()->set_frames(frames);
    const auto id = runner_->Submit(spec, activate).id();
    uint64_t version = 0;
    v1::Job job;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (std::chrono::steady_clock::now() < deadline) {
      EXPECT_TRUE(runner_->Watch(id, &version, std::chrono::milliseconds(500), &job));
      if (IsFinished(job.state())) break;
    }
    return job;
  }

  std::unique_ptr<sim::Scenario> scenario_;
  std::optional<kinematics::UrdfChain> chain_;
  CounterSet rejected_;
  SensorState sensors_{rejected_};
  RawFrameTap tap_;
  ActiveModels active_;
  std::filesystem::path dir_;
  std::unique_ptr<CalibrationStore> store_;
  std::unique_ptr<JobRunner> runner_;
  std::atomic<bool> feeding_{false};
  std::thread feeder_;
};

TEST_F(StereoJobTest, RecoversTheEncoderBiasAsACorrectionToTheKinematicPrior) {
  std::vector<Frame> frames;
  for (int i = 0; i < 6; ++i) frames.push_back(Render(17 + 47 * i));
  StartRunner(&*chain_);
  Feed(frames);
  const auto job = Run(6, /*activate=*/true);
  StopFeeding();
  ASSERT_EQ(job.state(), v1::SUCCEEDED) << job.message();
  EXPECT_EQ(job.model_id(), "stereo-extrinsics-1");
  const auto& e = job.errors();
  EXPECT_GE(e.frames_used(), 5u);
  EXPECT_NEAR(e.prior_rotation_deviation_deg(), 0.75, 0.1);  // the vergence bias
  EXPECT_LT(e.median_vertical_offset_px(), e.prior_median_vertical_offset_px());
  ASSERT_EQ(active_.stereo_id(), "stereo-extrinsics-1");
  // On frames the job never saw, prior * C is close to the truth.
  const auto& model = active_.stereo()->model;
  for (int index : {5, 150, 290}) {
    const Frame f = Render(index);
    const auto prior = calibration::KinematicPrior(*chain_, [&] {
      // joints in the chain's order
      std::vector<double> j;
      const auto names = scenario_->joint_names();
      for (const auto& n : chain_->joint_names()) {
        j.push_back(f.joints[static_cast<size_t>(std::find(names.begin(), names.end(), n) -
                                                 names.begin())]);
      }
      return j;
    }());
    const Eigen::Isometry3d corrected = model.Apply(prior);
    EXPECT_LT(calibration::RotationAngleDeg(corrected.linear(), f.truth.linear()), 0.2) << index;
    EXPECT_GT(calibration::RotationAngleDeg(prior.linear(), f.truth.linear()), 0.5) << index;
    EXPECT_LT(calibration::DirectionAngleDeg(corrected.translation(), f.truth.translation()), 1.0)
        << index;
  }
}

TEST_F(StereoJobTest, RefusesWithoutAUrdfWithCam1OrWithoutFrames) {
  StartRunner(nullptr);
  auto job = Run(3);
  EXPECT_EQ(job.state(), v1::FAILED);
  EXPECT_NE(job.message().find("--urdf"), std::string::npos) << job.message();

  const auto only_cam0 = kinematics::UrdfChain::FromString(R"(<robot name="mono">
    <link name="base_link"/><link name="cam0_optical"/>
    <joint name="j" type="fixed"><parent link="base_link"/><child link="cam0_optical"/></joint>
    </robot>)");
  runner_.reset();
  StartRunner(&only_cam0);
  job = Run(3);
  EXPECT_EQ(job.state(), v1::FAILED);
  EXPECT_NE(job.message().find("cam1_optical"), std::string::npos) << job.message();

  runner_.reset();
  StereoJobEnvironment env;
  env.tap = &tap_;
  env.sensors = &sensors_;
  env.chain = &*chain_;
  env.dds_domain = 42;
  env.settings.stereo_frame_timeout_ns = 300'000'000;
  runner_ = std::make_unique<JobRunner>(*store_, active_, env, 1);
  job = Run(3);
  EXPECT_EQ(job.state(), v1::FAILED);
  EXPECT_NE(job.message().find("no stereo frames arrived within 0.3 s"), std::string::npos)
      << job.message();
  EXPECT_NE(job.message().find("domain 42"), std::string::npos) << job.message();
  EXPECT_TRUE(store_->ListModels(v1::JOB_KIND_UNSPECIFIED).empty());
}

TEST_F(StereoJobTest, FeaturelessAndPlanarScenesFailWithAReason) {
  StartRunner(&*chain_);
  // Featureless: grey images (the camera looks at a blank wall).
  std::vector<Frame> blank;
  for (int i = 0; i < 3; ++i) {
    Frame f = Render(30 * i);
    f.stereo.left = cv::Mat(f.stereo.left.size(), f.stereo.left.type(), cv::Scalar::all(128));
    f.stereo.right = f.stereo.left.clone();
    blank.push_back(f);
  }
  Feed(blank);
  auto job = Run(3);
  StopFeeding();
  EXPECT_EQ(job.state(), v1::FAILED);
  EXPECT_NE(job.message().find("insufficient"), std::string::npos) << job.message();
  EXPECT_NE(job.message().find("textured scene"), std::string::npos) << job.message();

  // Planar: one textured wall 2 m away filling the view, seen through the true geometry.
  const auto cam0 = scenario_->cam0();
  Eigen::Matrix3d k;
  k << cam0.fu, 0, cam0.cu, 0, cam0.fv, cam0.cv, 0, 0, 1;
  const auto wall = calibration::testing::MakeQuad(Eigen::Vector3d(0, 0, 2.0), 6, 5, 0.3, 5);
  std::vector<Frame> planar;
  for (int i = 0; i < 3; ++i) {
    Frame f = Render(40 * i);
    const cv::Size size(cam0.width, cam0.height);
    cv::Mat l = calibration::testing::Render({wall}, k, Eigen::Isometry3d::Identity(), size);
    cv::Mat r = calibration::testing::Render({wall}, k, f.truth, size);
    cv::cvtColor(l, f.stereo.left, cv::COLOR_GRAY2BGR);
    cv::cvtColor(r, f.stereo.right, cv::COLOR_GRAY2BGR);
    planar.push_back(f);
  }
  Feed(planar);
  job = Run(3);
  StopFeeding();
  EXPECT_EQ(job.state(), v1::FAILED);
  EXPECT_NE(job.message().find("planar"), std::string::npos) << job.message();
  EXPECT_TRUE(store_->ListModels(v1::JOB_KIND_UNSPECIFIED).empty());
  EXPECT_FALSE(active_.stereo());
}

}  // namespace
}  // namespace epmap::mapping
