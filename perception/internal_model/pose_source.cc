#include "perception/internal_model/pose_source.h"

#include <cmath>
#include <stdexcept>

namespace epmap::internal_model {

void CheckRigid(const Eigen::Isometry3d& T, const std::string& what) {
  if (!T.matrix().allFinite()) throw std::invalid_argument(what + ": pose is not finite");
  const Eigen::Matrix3d R = T.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
      std::abs(R.determinant() - 1.0) > 1e-6) {
    throw std::invalid_argument(what + ": rotation is not orthonormal and right-handed");
  }
}

UrdfPoseSource::UrdfPoseSource(kinematics::UrdfChain chain,
                               const std::vector<std::string>& joint_order)
    : chain_(std::move(chain)) {
  chain_.BindJointOrder(joint_order);  // throws listing the chain joints the readings lack
}

Eigen::Isometry3d UrdfPoseSource::CameraPose(const PoseInput& input) const {
  return chain_.Cam0Pose(input.joints);  // throws on a wrong count or a NaN reading
}

LearnedPoseSource::LearnedPoseSource(LearnedPoseModel model,
                                     const std::vector<std::string>& joint_order)
    : model_(std::move(model)), expected_columns_(joint_order.size()) {
  std::string missing;
  for (const auto& name : model_.input_joint_names()) {
    size_t found = joint_order.size();
    for (size_t i = 0; i < joint_order.size(); ++i) {
      if (joint_order[i] == name) found = i;
    }
    if (found == joint_order.size()) {
      missing += (missing.empty() ? "" : ", ") + name;
    } else {
      input_columns_.push_back(found);
    }
  }
  if (!missing.empty()) {
    throw std::invalid_argument("joint readings lack the learned model's inputs: " + missing);
  }
}

Eigen::Isometry3d LearnedPoseSource::CameraPose(const PoseInput& input) const {
  if (input.joints.size() != expected_columns_) {
    throw std::invalid_argument("expected " + std::to_string(expected_columns_) +
                                " joint values, got " + std::to_string(input.joints.size()));
  }
  std::vector<double> q;
  q.reserve(input_columns_.size());
  for (size_t c : input_columns_) q.push_back(input.joints[c]);
  return model_.Predict(q);
}

Eigen::Isometry3d DirectPoseSource::CameraPose(const PoseInput& input) const {
  if (!input.T_base_cam0) {
    throw std::invalid_argument("the direct pose source needs a pose at every frame; none given");
  }
  CheckRigid(*input.T_base_cam0, "direct pose");
  return *input.T_base_cam0;
}

FixedPoseSource::FixedPoseSource(const Eigen::Isometry3d& T_base_cam0) : T_base_cam0_(T_base_cam0) {
  CheckRigid(T_base_cam0_, "fixed pose");
}

Eigen::Isometry3d FixedPoseSource::CameraPose(const PoseInput&) const {
  return T_base_cam0_;
}

Eigen::Isometry3d BaseOnOdometry(double x, double y, double theta) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  T.linear() = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

Eigen::Isometry3d RootOnOdometry(const Eigen::Isometry3d& T_odom_child,
                                 const Eigen::Isometry3d& T_root_child) {
  const Eigen::Isometry3d T_odom_root = T_odom_child * T_root_child.inverse();
  const Eigen::Vector3d x_axis = T_odom_root.linear().col(0);
  return BaseOnOdometry(T_odom_root.translation().x(), T_odom_root.translation().y(),
                        std::atan2(x_axis.y(), x_axis.x()));
}

}  // namespace epmap::internal_model
