#pragma once
// Joint limits from a URDF, for the key frame checks of MobileMapper.

#include <filesystem>
#include <string>
#include <vector>

#include "perception/mobile_mapping/mobile_mapper.h"

namespace epmap::mobile_mapping {

// Limits of the named joints, in that order. Continuous joints get [-inf, inf]. Throws
// std::runtime_error for an unreadable URDF or a joint it does not have.
std::vector<JointLimit> JointLimitsFromUrdf(const std::string& urdf_xml,
                                            const std::vector<std::string>& joint_names);
// The same, from a URDF file.
std::vector<JointLimit> JointLimitsFromUrdfFile(const std::filesystem::path& urdf,
                                                const std::vector<std::string>& joint_names);

}  // namespace epmap::mobile_mapping
