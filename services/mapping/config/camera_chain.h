#pragma once
// The kinematic chain robot.urdf describes, from its root link to the cameras' optical links
// robot.left_camera_link and robot.right_camera_link name. The pipeline (camera poses) and the
// calibration service (stereo prior) each load their own copy.

#include "perception/kinematics/urdf_chain.h"
#include "services/mapping/config/service_config.h"

namespace epmap::mapping {

// Throws std::runtime_error with the URDF's complaint and the settings that name the links.
kinematics::UrdfChain LoadCameraChain(const ServiceConfig& config);

// What `epmapd --check-robot` prints: the chain's root and camera links, the joints the service
// will read from rt/joint_states with their limits, and the cameras' poses at zero joints, so a
// robot's URDF and config can be checked before the service runs. Throws like LoadCameraChain.
std::string DescribeCameraChain(const ServiceConfig& config);

}  // namespace epmap::mapping
