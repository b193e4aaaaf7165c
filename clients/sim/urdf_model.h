#pragma once
// The URDFs shipped in clients/sim/urdf (compiled in), and the "true" chains the worlds are
// rendered with: the shipped one with small unmodelled offsets, as a real robot differs from
// its CAD model.

#include <Eigen/Core>
#include <string>

namespace epmap::sim {

const char* IcubHeadUrdf();  // clients/sim/urdf/icub_head.urdf
const char* PanRobotUrdf();  // clients/sim/urdf/pan_robot.urdf

// Returns `urdf` with the <origin> of joint `joint` moved by d_xyz (metres) and d_rpy (radians,
// added to its roll, pitch, yaw). Throws std::invalid_argument if the joint or its origin is
// not found.
std::string PerturbJointOrigin(const std::string& urdf, const std::string& joint,
                               const Eigen::Vector3d& d_xyz, const Eigen::Vector3d& d_rpy);

}  // namespace epmap::sim
