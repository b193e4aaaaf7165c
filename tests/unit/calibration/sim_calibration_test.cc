// The calibration algorithms on the project's synthetic worlds (clients/sim): the eye-hand
// scenario's workspace-dependent error (paper 001, Sec. IV-A targets), and the vergence
// scenario's unrectified pairs with biased eye encoders against the true per-frame extrinsics.
// Renders in-process: labelled slow.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "clients/sim/scenario.h"
#include "perception/calibration/dataset_intrinsics.h"
#include "perception/calibration/eye_hand_calibration.h"
#include "perception/calibration/stereo_self_calibration.h"
#include "perception/kinematics/urdf_chain.h"

namespace epmap::calibration {
namespace {

TEST(SimCalibration, EyeHandMixtureMeetsThePapersTarget) {
  const auto scenario = sim::MakeScenario({.name = "eye-hand"});
  std::vector<EyeHandSample> samples;
  for (const auto& s : scenario->EyeHandSamples())
    samples.push_back({s.stamp_ns, s.xa, s.xb, s.path});
  ASSERT_EQ(samples.size(), 2000u);
  const PathSplit split = SplitByPaths(samples, 0.25, 1);  // 15 paths to train, 5 to test
  EyeHandCalibrationParams se3, mixture;
  mixture.method = EyeHandMethod::kMixture;  // K = 4, the paper's choice
  const auto a = CalibrateEyeHand(split.train, split.test, se3);
  const auto b = CalibrateEyeHand(split.train, split.test, mixture);
  EXPECT_GT(a.errors.initial.mean_m, 0.03);
  EXPECT_LT(a.errors.test.mean_m, a.errors.initial.mean_m / 2);
  EXPECT_LT(b.errors.test.mean_m, 0.011);  // paper 001, Sec. IV-A: 1.1 cm
  EXPECT_LT(b.errors.test.mean_m, 0.75 * a.errors.test.mean_m);
}

TEST(SimCalibration, VergenceExtrinsicsRecoveredFromBiasedEncoders) {
  const auto scenario = sim::MakeScenario({.name = "vergence", .frames = 240});
  auto chain = kinematics::UrdfChain::FromString(scenario->urdf());
  chain.BindJointOrder(scenario->joint_names());
  const CameraIntrinsics c0 = IntrinsicsOf(scenario->cam0()), c1 = IntrinsicsOf(scenario->cam1());
  for (int index : {0, 120, 239}) {
    const sim::SimFrame f = scenario->Render(index);
    StereoView v;
    v.left = f.left;
    v.right = f.right;
    v.T_cam0_cam1_prior = KinematicPrior(chain, f.joints);
    const Eigen::Isometry3d& truth = f.gt_T_cam0_cam1;
    // The encoders' bias puts the prior the better part of a degree off.
    ASSERT_GT(RotationAngleDeg(v.T_cam0_cam1_prior.linear(), truth.linear()), 0.5);
    const auto r = SelfCalibrateStereo(c0, c1, {v});
    EXPECT_LT(RotationAngleDeg(r.model.T_cam0_cam1.linear(), truth.linear()), 0.2) << index;
    EXPECT_LT(DirectionAngleDeg(r.model.T_cam0_cam1.translation(), truth.translation()), 2.0)
        << index;
    EXPECT_LT(MedianRowOffset(c0, c1, r.model.T_cam0_cam1, v.left, v.right), 0.5) << index;
    // With the baseline-direction prior the direction lands within a degree.
    StereoSelfCalibrationParams with_prior;
    with_prior.baseline_direction_prior_sigma_deg = 0.5;
    const auto p = SelfCalibrateStereo(c0, c1, {v}, with_prior);
    EXPECT_LT(DirectionAngleDeg(p.model.T_cam0_cam1.translation(), truth.translation()), 1.0)
        << index;
  }
}

}  // namespace
}  // namespace epmap::calibration
