#include "services/mapping/config/camera_chain.h"

#include <stdexcept>

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

}  // namespace epmap::mapping
