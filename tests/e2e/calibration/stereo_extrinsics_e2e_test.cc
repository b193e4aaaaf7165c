// The stereo-extrinsics job through the whole service: epmap-sim publishes the vergence
// scenario (verging eyes, biased eye encoders, raw unrectified images, CameraInfo with K only)
// over DDS, epmapd (with the shipped head URDF, the nominal chain) runs the job on live frames,
// and the model it yields is checked against the sim's true extrinsics on frames the job never
// saw; once active, the pipeline rectifies the verged pairs with it and computes disparity.

#include <gtest/gtest.h>

#include <algorithm>

#include "perception/calibration/dataset_intrinsics.h"
#include "perception/calibration/stereo_self_calibration.h"
#include "services/mapping/calibration/stereo_correction.h"
#include "tests/e2e/calibration/calibration_e2e.h"

namespace epmap::testing {
namespace {

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? NAN : v[v.size() / 2];
}

TEST(CalibrationStereoE2e, VergenceExtrinsicsFromTheLiveStream) {
  const auto work = FreshTempDir("calib-stereo-e2e");
  const auto urdf = SourceDir() / "clients/sim/urdf/icub_head.urdf";
  Epmapd epmapd(UniqueDomainId(61), {"--state-dir", work / "state", "--urdf", urdf}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();
  const std::string domain = std::to_string(epmapd.domain());
  ChildProcess publisher(BinDir() / "epmap-sim",
                         {"publish", "--scenario", "vergence", "--domain", domain},
                         work / "sim.log");
  auto stub = CalibrationStub(epmapd.address());
  v1::StartJobRequest start;
  start.mutable_spec()->mutable_stereo_extrinsics()->set_frames(10);
  start.set_activate_on_success(true);
  v1::Job job;
  ASSERT_TRUE(stub->StartJob(Deadline().get(), start, &job).ok());
  job = WaitJob(
      *stub, job.id(), [](const v1::Job& j) { return Finished(j.state()); },
      std::chrono::seconds(400));
  ASSERT_EQ(job.state(), v1::SUCCEEDED) << job.message() << "\n" << epmapd.process().Output();
  const auto& e = job.errors();
  std::printf(
      "job: %u frames used, %u refused; correction %.3f deg; vertical offset %.3f px "
      "(prior %.3f px)\n",
      e.frames_used(), e.frames_failed(), e.prior_rotation_deviation_deg(),
      e.median_vertical_offset_px(), e.prior_median_vertical_offset_px());
  EXPECT_GE(e.frames_used(), 5u);
  EXPECT_LE(e.median_vertical_offset_px(), 0.5);

  v1::ListModelsResponse models;
  ASSERT_TRUE(stub->ListModels(Deadline().get(), {}, &models).ok());
  ASSERT_EQ(models.models_size(), 1);
  EXPECT_TRUE(models.models(0).active());
  const auto model = mapping::StereoCorrectionModel::FromJson(models.models(0).parameters_json());

  // Against the truth, on frames spread over the sequence (the job used the first seconds).
  const auto scenario = sim::MakeScenario({.name = "vergence"});
  const auto chain = kinematics::UrdfChain::FromFile(urdf);
  const auto names = scenario->joint_names();
  const auto c0 = calibration::IntrinsicsOf(scenario->cam0()),
             c1 = calibration::IntrinsicsOf(scenario->cam1());
  std::vector<double> rotation, direction, offset, prior_rotation;
  for (int index = 15; index < 300; index += 30) {
    const auto f = scenario->Render(index);
    std::vector<double> joints;
    for (const auto& n : chain.joint_names()) {
      joints.push_back(
          f.joints[static_cast<size_t>(std::find(names.begin(), names.end(), n) - names.begin())]);
    }
    const auto prior = calibration::KinematicPrior(chain, joints);
    const Eigen::Isometry3d corrected = model.Apply(prior);
    rotation.push_back(
        calibration::RotationAngleDeg(corrected.linear(), f.gt_T_cam0_cam1.linear()));
    prior_rotation.push_back(
        calibration::RotationAngleDeg(prior.linear(), f.gt_T_cam0_cam1.linear()));
    direction.push_back(
        calibration::DirectionAngleDeg(corrected.translation(), f.gt_T_cam0_cam1.translation()));
    offset.push_back(calibration::MedianRowOffset(c0, c1, corrected, f.left, f.right));
  }
  std::printf(
      "truth, median of %zu frames: rotation %.3f deg (prior %.3f), baseline direction "
      "%.3f deg, vertical offset %.3f px\n",
      rotation.size(), Median(rotation), Median(prior_rotation), Median(direction), Median(offset));
  EXPECT_LE(Median(rotation), 0.2);
  EXPECT_LE(*std::max_element(rotation.begin(), rotation.end()), 0.2);
  EXPECT_LE(Median(direction), 1.0);
  EXPECT_LE(Median(offset), 0.5);

  // The active model replaces CameraInfo's rectification (which cannot rectify this rig).
  publisher.Wait(std::chrono::seconds(30));
  ChildProcess more(BinDir() / "epmap-sim",
                    {"publish", "--scenario", "vergence", "--domain", domain, "--frames", "60"},
                    work / "sim2.log");
  const auto status =
      epmapd.WaitStatus([](const v1::ServiceStatus& s) { return s.frames_processed() >= 5; },
                        std::chrono::seconds(60));
  EXPECT_GE(status.frames_processed(), 5u) << epmapd.process().Output();
  EXPECT_EQ(status.active_stereo_model(), "stereo-extrinsics-1");
  EXPECT_GT(Epmapd::Count(status.events(), "stereo_model_rectification_rebuilt"), 0u);
  more.Wait(std::chrono::seconds(30));
  std::filesystem::remove_all(work);
}

}  // namespace
}  // namespace epmap::testing
