#pragma once
// The internal model's interface (paper 000, Sec. II "Internal Model" block and Sec. IV: the map
// T : R^I -> SE(3) that turns odometry into the camera pose T^k = T(theta^k)). The EP pipeline
// only needs T_base_cam0 at each frame; where it comes from is a choice of the deployment:
//   - UrdfPoseSource: forward kinematics of the URDF chain (orocos-KDL);
//   - LearnedPoseSource: the paper's multilayer perceptron (learned_pose_model.h);
//   - DirectPoseSource: a pose given directly (an odometry or pose topic);
//   - FixedPoseSource: a static rig (no kinematics at all).

#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "perception/internal_model/learned_pose_model.h"
#include "perception/kinematics/urdf_chain.h"

namespace epmap::internal_model {

// What is known at one frame. Each source reads only what it needs and throws
// std::invalid_argument naming what is missing.
struct PoseInput {
  std::vector<double> joints;                    // encoder readings, in the source's bound order
  std::optional<Eigen::Isometry3d> T_base_cam0;  // an externally supplied pose, if any
};

class PoseSource {
 public:
  virtual ~PoseSource() = default;
  // T_base_cam0 at this frame (rotation orthonormal, all values finite), or
  // std::invalid_argument with the reason.
  virtual Eigen::Isometry3d CameraPose(const PoseInput& input) const = 0;
  // A short name for logs and benchmark JSON ("urdf", "learned", "direct", "fixed").
  virtual std::string Name() const = 0;
};

// Forward kinematics of a URDF chain. `joint_order` names the columns of the readings (e.g.
// joints0's names); every joint on the way to cam0_optical must be among them (else
// std::invalid_argument listing the missing ones).
class UrdfPoseSource final : public PoseSource {
 public:
  UrdfPoseSource(kinematics::UrdfChain chain, const std::vector<std::string>& joint_order);
  Eigen::Isometry3d CameraPose(const PoseInput& input) const override;
  std::string Name() const override { return "urdf"; }
  const kinematics::UrdfChain& chain() const { return chain_; }

 private:
  kinematics::UrdfChain chain_;
};

// The learned internal model. The model's own input joints (e.g. the three neck angles) are
// picked by name out of the readings, whose column names are `joint_order`.
class LearnedPoseSource final : public PoseSource {
 public:
  LearnedPoseSource(LearnedPoseModel model, const std::vector<std::string>& joint_order);
  Eigen::Isometry3d CameraPose(const PoseInput& input) const override;
  std::string Name() const override { return "learned"; }
  const LearnedPoseModel& model() const { return model_; }

 private:
  LearnedPoseModel model_;
  std::vector<size_t> input_columns_;  // model input i = readings[input_columns_[i]]
  size_t expected_columns_ = 0;
};

// Passes through PoseInput::T_base_cam0 (after checking it is a finite rigid transform).
class DirectPoseSource final : public PoseSource {
 public:
  Eigen::Isometry3d CameraPose(const PoseInput& input) const override;
  std::string Name() const override { return "direct"; }
};

// A camera that never moves relative to the base (a fixed stereo rig).
class FixedPoseSource final : public PoseSource {
 public:
  explicit FixedPoseSource(const Eigen::Isometry3d& T_base_cam0 = Eigen::Isometry3d::Identity());
  Eigen::Isometry3d CameraPose(const PoseInput& input) const override;
  std::string Name() const override { return "fixed"; }

 private:
  Eigen::Isometry3d T_base_cam0_;
};

// A mobile base's planar odometry reading (x, y in metres, theta in radians about z) as the
// base's pose in the odometry frame: the camera rides on it, T_odom_cam0 = T_odom_base T_base_cam0.
Eigen::Isometry3d BaseOnOdometry(double x, double y, double theta);

// The URDF root's pose on the floor when odometry moves another link of the robot (e.g. rt/odom
// of base_link, a URDF rooted at base_footprint): T_odom_root = T_odom_child T_root_child^-1,
// flattened to the plane (its x, y and the heading of its x axis) because the maps and the base
// pose are planar.
Eigen::Isometry3d RootOnOdometry(const Eigen::Isometry3d& T_odom_child,
                                 const Eigen::Isometry3d& T_root_child);

// Throws std::invalid_argument (prefixed by `what`) unless T is finite with an orthonormal,
// right-handed rotation (tolerance 1e-6).
void CheckRigid(const Eigen::Isometry3d& T, const std::string& what);

}  // namespace epmap::internal_model
