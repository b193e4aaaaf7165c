#include <gtest/gtest.h>

#include <fstream>
#include <numbers>
#include <random>

#include "perception/internal_model/learned_pose_model.h"
#include "perception/internal_model/pose_source.h"
#include "tests/support/head_urdf.h"
#include "tests/support/test_env.h"

namespace epmap {
namespace {

using internal_model::LearnedModelParams;
using internal_model::LearnedPoseModel;
using internal_model::PoseInput;

const std::vector<std::string> kColumns = {"neck_pitch", "neck_roll",    "neck_yaw",
                                           "eyes_tilt",  "left_eye_pan", "right_eye_pan"};
const std::vector<std::string> kNeck = {"neck_pitch", "neck_roll", "neck_yaw"};

// (neck angles, T_base_cam0) pairs from the URDF chain over a neck range, eyes still.
void SampleNeck(int n, double range, uint64_t seed, std::vector<std::vector<double>>* inputs,
                std::vector<Eigen::Isometry3d>* poses) {
  auto chain = kinematics::UrdfChain::FromString(testing::kHeadUrdf);
  chain.BindJointOrder(kColumns);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-range, range);
  for (int i = 0; i < n; ++i) {
    const std::vector<double> q = {u(rng), u(rng), u(rng)};
    inputs->push_back(q);
    poses->push_back(chain.Cam0Pose({q[0], q[1], q[2], 0.0, 0.0, 0.0}));
  }
}

TEST(PoseSources, UrdfSourceBindsColumnsByName) {
  // Readings in another order than the chain, with an extra column.
  const std::vector<std::string> columns = {"left_eye_pan",  "extra",     "neck_yaw",  "neck_roll",
                                            "right_eye_pan", "eyes_tilt", "neck_pitch"};
  internal_model::UrdfPoseSource source(kinematics::UrdfChain::FromString(testing::kHeadUrdf),
                                        columns);
  auto reference = kinematics::UrdfChain::FromString(testing::kHeadUrdf);
  reference.BindJointOrder(kColumns);
  const Eigen::Isometry3d T =
      source.CameraPose(PoseInput{{0.0, 5.0, 0.3, -0.1, 0.0, 0.0, 0.2}, std::nullopt});
  const Eigen::Isometry3d expected = reference.Cam0Pose({0.2, -0.1, 0.3, 0.0, 0.0, 0.0});
  EXPECT_TRUE(T.isApprox(expected, 1e-12));
  EXPECT_EQ(source.Name(), "urdf");
}

TEST(PoseSources, MissingJointsAndMissingCameraAreClearErrors) {
  try {
    internal_model::UrdfPoseSource(kinematics::UrdfChain::FromString(testing::kHeadUrdf),
                                   {"neck_pitch", "neck_roll"});
    FAIL() << "missing joints accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("neck_yaw"), std::string::npos) << e.what();
  }
  std::string no_cam = testing::kHeadUrdf;
  for (size_t p; (p = no_cam.find("cam0_optical")) != std::string::npos;) {
    no_cam.replace(p, 12, "camX_optical");
  }
  EXPECT_THROW(kinematics::UrdfChain::FromString(no_cam), std::runtime_error);
  internal_model::UrdfPoseSource source(kinematics::UrdfChain::FromString(testing::kHeadUrdf),
                                        kColumns);
  EXPECT_THROW(source.CameraPose(PoseInput{{0.1, 0.2}, std::nullopt}), std::invalid_argument);
  EXPECT_THROW(source.CameraPose(PoseInput{{0, 0, std::nan(""), 0, 0, 0}, std::nullopt}),
               std::invalid_argument);
}

TEST(PoseSources, DirectAndFixed) {
  internal_model::DirectPoseSource direct;
  EXPECT_THROW(direct.CameraPose(PoseInput{}), std::invalid_argument);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translate(Eigen::Vector3d(1, 2, 3)).rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  EXPECT_TRUE(direct.CameraPose(PoseInput{{}, T}).isApprox(T));
  Eigen::Isometry3d bad = T;
  bad.matrix()(0, 0) = 2.0;
  EXPECT_THROW(direct.CameraPose(PoseInput{{}, bad}), std::invalid_argument);
  bad.matrix()(0, 0) = std::nan("");
  EXPECT_THROW(direct.CameraPose(PoseInput{{}, bad}), std::invalid_argument);
  internal_model::FixedPoseSource fixed(T);
  EXPECT_TRUE(fixed.CameraPose(PoseInput{{0.5}, std::nullopt}).isApprox(T));
}

TEST(PoseSources, TheBaseOnOdometryTurnsAboutTheVerticalAxis) {
  // A base at (2, 1) facing +y: a point 1 m ahead of it, 0.5 m up, is at (2, 2, 0.5).
  const Eigen::Isometry3d T = internal_model::BaseOnOdometry(2.0, 1.0, std::numbers::pi / 2);
  EXPECT_TRUE((T * Eigen::Vector3d(1, 0, 0.5)).isApprox(Eigen::Vector3d(2, 2, 0.5)));
}

TEST(PoseSources, TheRootOnOdometryOfAnotherLink) {
  // rt/odom moves base_link, 0.3 m ahead of and 0.1 m above the URDF's root (base_footprint),
  // turned 0.2 rad; the odometry says base_link is at (2, 1) facing +y.
  Eigen::Isometry3d T_root_child = Eigen::Isometry3d::Identity();
  T_root_child.translation() = Eigen::Vector3d(0.3, 0.0, 0.1);
  T_root_child.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Isometry3d T_odom_child =
      internal_model::BaseOnOdometry(2.0, 1.0, std::numbers::pi / 2);
  const Eigen::Isometry3d T_odom_root = internal_model::RootOnOdometry(T_odom_child, T_root_child);
  // The root faces 0.2 rad less than the child and stays on the floor (z = 0, planar).
  EXPECT_NEAR(T_odom_root.translation().z(), 0.0, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(T_odom_root.linear()).angle(), std::numbers::pi / 2 - 0.2, 1e-12);
  // Composed back, the child lands where the odometry put it (in x, y).
  const Eigen::Isometry3d back = T_odom_root * T_root_child;
  EXPECT_TRUE(back.translation().head<2>().isApprox(Eigen::Vector2d(2.0, 1.0), 1e-12));
  EXPECT_TRUE(back.linear().isApprox(T_odom_child.linear(), 1e-12));
  // The identity leaves the reading as it is.
  EXPECT_TRUE(internal_model::RootOnOdometry(T_odom_child, Eigen::Isometry3d::Identity())
                  .isApprox(T_odom_child, 1e-12));
}

// Sec. III: 3 neck inputs, 10 hidden units, 12 outputs, 70/15/15, 300 samples, trained until the
// validation error is below the paper's 6e-6.
TEST(LearnedPoseModel, LearnsTheNeckChainAndRoundTripsThroughAFile) {
  std::vector<std::vector<double>> inputs;
  std::vector<Eigen::Isometry3d> poses;
  SampleNeck(300, 0.3, 7, &inputs, &poses);
  const LearnedPoseModel model = LearnedPoseModel::Train(kNeck, inputs, poses);
  const auto& r = model.report();
  EXPECT_TRUE(r.reached_target);
  EXPECT_EQ(r.train_samples, 210u);
  EXPECT_EQ(r.validation_samples, 45u);
  EXPECT_EQ(r.test_samples, 45u);
  EXPECT_LT(r.validation_error, 6e-6);
  EXPECT_LT(r.test_error, 2e-5);
  EXPECT_LT(r.test_rotation_rms_rad, 0.01);
  EXPECT_LT(r.test_translation_rms_m, 0.002);
  // The translation scale is the base-to-eye distance of the test head (about 0.27 m).
  EXPECT_GT(r.lever_arm_m, 0.1);

  // A fresh sample from the same range is predicted as a rigid transform close to the chain.
  std::vector<std::vector<double>> q;
  std::vector<Eigen::Isometry3d> truth;
  SampleNeck(20, 0.3, 99, &q, &truth);
  for (size_t i = 0; i < q.size(); ++i) {
    const Eigen::Isometry3d T = model.Predict(q[i]);
    EXPECT_NEAR((T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm(), 0,
                1e-9);
    EXPECT_LT(Eigen::AngleAxisd(truth[i].linear().transpose() * T.linear()).angle(), 0.02);
    EXPECT_LT((truth[i].translation() - T.translation()).norm(), 0.004);
  }

  const auto dir = testing::FreshTempDir("learned-model");
  model.Save(dir / "model.yml");
  const LearnedPoseModel loaded = LearnedPoseModel::Load(dir / "model.yml");
  EXPECT_EQ(loaded.input_joint_names(), kNeck);
  EXPECT_DOUBLE_EQ(loaded.report().validation_error, r.validation_error);
  EXPECT_TRUE(loaded.Predict(q[0]).isApprox(model.Predict(q[0]), 1e-6));
  EXPECT_NEAR(loaded.Error(q, truth), model.Error(q, truth), 1e-9);

  // As a pose source it picks the neck columns out of the full readings by name.
  internal_model::LearnedPoseSource source(LearnedPoseModel::Load(dir / "model.yml"), kColumns);
  const Eigen::Isometry3d T =
      source.CameraPose(PoseInput{{q[0][0], q[0][1], q[0][2], 0, 0, 0}, {}});
  EXPECT_TRUE(T.isApprox(model.Predict(q[0]), 1e-6));
  EXPECT_THROW(internal_model::LearnedPoseSource(LearnedPoseModel::Load(dir / "model.yml"),
                                                 {"neck_pitch", "eyes_tilt"}),
               std::invalid_argument);
  std::filesystem::remove_all(dir);
}

TEST(LearnedPoseModel, BadInputIsAClearError) {
  std::vector<std::vector<double>> inputs;
  std::vector<Eigen::Isometry3d> poses;
  SampleNeck(10, 0.3, 1, &inputs, &poses);
  EXPECT_THROW(LearnedPoseModel::Train(kNeck, inputs, poses), std::invalid_argument);  // < 20
  SampleNeck(30, 0.3, 2, &inputs, &poses);
  inputs[3][1] = std::nan("");
  EXPECT_THROW(LearnedPoseModel::Train(kNeck, inputs, poses), std::invalid_argument);
  inputs[3][1] = 0.1;
  inputs[4].pop_back();
  EXPECT_THROW(LearnedPoseModel::Train(kNeck, inputs, poses), std::invalid_argument);
  const auto dir = testing::FreshTempDir("learned-model-bad");
  EXPECT_THROW(LearnedPoseModel::Load(dir / "absent.yml"), std::runtime_error);
  { std::ofstream(dir / "junk.yml") << "%YAML:1.0\nformat: something-else\n"; }
  EXPECT_THROW(LearnedPoseModel::Load(dir / "junk.yml"), std::runtime_error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace epmap
