#include "perception/mobile_mapping/joint_limits.h"

#include <urdf_parser/urdf_parser.h>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace epmap::mobile_mapping {

std::vector<JointLimit> JointLimitsFromUrdf(const std::string& urdf_xml,
                                            const std::vector<std::string>& joint_names) {
  const auto model = urdf::parseURDF(urdf_xml);
  if (!model) throw std::runtime_error("joint limits: the URDF cannot be parsed");
  std::vector<JointLimit> out;
  for (const auto& name : joint_names) {
    const auto joint = model->getJoint(name);
    if (!joint) throw std::runtime_error("joint limits: the URDF has no joint '" + name + "'");
    JointLimit lim{name, -std::numeric_limits<double>::infinity(),
                   std::numeric_limits<double>::infinity()};
    if (joint->type != urdf::Joint::CONTINUOUS && joint->limits) {
      lim.lower = joint->limits->lower;
      lim.upper = joint->limits->upper;
    }
    out.push_back(lim);
  }
  return out;
}

std::vector<JointLimit> JointLimitsFromUrdfFile(const std::filesystem::path& urdf,
                                                const std::vector<std::string>& joint_names) {
  std::ifstream in(urdf);
  if (!in) throw std::runtime_error("cannot read the URDF " + urdf.string());
  std::stringstream xml;
  xml << in.rdbuf();
  return JointLimitsFromUrdf(xml.str(), joint_names);
}

}  // namespace epmap::mobile_mapping
