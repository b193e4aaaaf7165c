#include "services/mapping/config/camera_chain.h"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

#include "perception/mobile_mapping/joint_limits.h"

namespace epmap::mapping {

kinematics::UrdfChain LoadCameraChain(const ServiceConfig& config) {
  try {
    return kinematics::UrdfChain::FromFile(config.urdf,
                                           {config.left_camera_link, config.right_camera_link});
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string(e.what()) +
                             "; robot.left_camera_link and robot.right_camera_link name the "
                             "cameras' optical links");
  }
}

namespace {

std::string PoseText(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d t = T.translation();
  const Eigen::AngleAxisd r(T.linear());
  return fmt::format(
      "translation ({:.4f}, {:.4f}, {:.4f}) m, rotation {:.2f} deg about ({:.3f}, "
      "{:.3f}, {:.3f})",
      t.x(), t.y(), t.z(), r.angle() * 180 / M_PI, r.axis().x(), r.axis().y(), r.axis().z());
}

}  // namespace

std::string DescribeCameraChain(const ServiceConfig& config) {
  if (config.urdf.empty()) {
    return "no URDF (robot.urdf / --urdf): no kinematic chain, so the EP predicts with a fixed "
           "camera and a mobile base's maps refuse key frames (maps:no_urdf)\n";
  }
  const auto chain = LoadCameraChain(config);
  std::string out =
      fmt::format("URDF {}\n  root link (the base): {}\n", config.urdf, chain.root_link());
  out += fmt::format(
      "  left camera link: {}\n  right camera link: {}\n", config.left_camera_link,
      chain.has_cam1() ? config.right_camera_link : "(absent: no stereo-extrinsics calibration)");
  const auto fixed = chain.LinksFixedToRoot();
  out += fmt::format(
      "  rt/odom's child_frame_id may be the root or a link fixed to it ({}): {}\n"
      "    (another link is composed through the joints read; a frame the URDF lacks is taken "
      "for the root, with a warning)\n",
      fixed.size(), fmt::join(fixed, ", "));
  const auto limits = mobile_mapping::JointLimitsFromUrdfFile(config.urdf, chain.joint_names());
  out += fmt::format("  joints read from {} ({}):\n", config.topics.joints, limits.size());
  for (const auto& l : limits) {
    out += std::isfinite(l.lower)
               ? fmt::format("    {} [{:.4f}, {:.4f}]\n", l.name, l.lower, l.upper)
               : fmt::format("    {} (continuous)\n", l.name);
  }
  const std::vector<double> zeros(chain.joint_names().size(), 0.0);
  out += fmt::format("  at zero joints: {} -> {}: {}\n", chain.root_link(), config.left_camera_link,
                     PoseText(chain.Cam0Pose(zeros)));
  if (chain.has_cam1()) {
    const Eigen::Isometry3d T_left_right = chain.Cam0Pose(zeros).inverse() * chain.Cam1Pose(zeros);
    out += fmt::format("  baseline at zero joints: {:.4f} m ({} -> {}: {})\n",
                       T_left_right.translation().norm(), config.left_camera_link,
                       config.right_camera_link, PoseText(T_left_right));
  }
  return out;
}

}  // namespace epmap::mapping
