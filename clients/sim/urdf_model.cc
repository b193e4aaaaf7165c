#include "clients/sim/urdf_model.h"

#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace epmap::sim {

namespace {

// The value of attribute `name` in the element text [begin, end), as three numbers, and where
// its quoted value sits.
bool FindTriple(const std::string& text, size_t begin, size_t end, const std::string& name,
                Eigen::Vector3d* value, size_t* value_begin, size_t* value_end) {
  const size_t at = text.find(" " + name + "=\"", begin);
  if (at == std::string::npos || at >= end) return false;
  *value_begin = at + name.size() + 3;
  *value_end = text.find('"', *value_begin);
  if (*value_end == std::string::npos || *value_end >= end) return false;
  std::istringstream in(text.substr(*value_begin, *value_end - *value_begin));
  return static_cast<bool>(in >> (*value)[0] >> (*value)[1] >> (*value)[2]);
}

std::string Format(const Eigen::Vector3d& v) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "%.17g %.17g %.17g", v[0], v[1], v[2]);
  return buf;
}

}  // namespace

std::string PerturbJointOrigin(const std::string& urdf, const std::string& joint,
                               const Eigen::Vector3d& d_xyz, const Eigen::Vector3d& d_rpy) {
  const size_t joint_at = urdf.find("<joint name=\"" + joint + "\"");
  if (joint_at == std::string::npos) {
    throw std::invalid_argument("PerturbJointOrigin: no joint named '" + joint + "'");
  }
  const size_t joint_end = urdf.find("</joint>", joint_at);
  const size_t origin_at = urdf.find("<origin", joint_at);
  if (origin_at == std::string::npos || origin_at > joint_end) {
    throw std::invalid_argument("PerturbJointOrigin: joint '" + joint + "' has no <origin>");
  }
  const size_t origin_end = urdf.find("/>", origin_at);
  Eigen::Vector3d xyz, rpy;
  size_t xb, xe, rb, re;
  if (!FindTriple(urdf, origin_at, origin_end, "xyz", &xyz, &xb, &xe) ||
      !FindTriple(urdf, origin_at, origin_end, "rpy", &rpy, &rb, &re)) {
    throw std::invalid_argument("PerturbJointOrigin: the <origin> of joint '" + joint +
                                "' needs xyz and rpy");
  }
  std::string out = urdf;
  // Replace the later attribute first so the earlier offsets stay valid.
  const bool xyz_first = xb < rb;
  const auto replace = [&](size_t b, size_t e, const std::string& v) { out.replace(b, e - b, v); };
  if (xyz_first) {
    replace(rb, re, Format(rpy + d_rpy));
    replace(xb, xe, Format(xyz + d_xyz));
  } else {
    replace(xb, xe, Format(xyz + d_xyz));
    replace(rb, re, Format(rpy + d_rpy));
  }
  return out;
}

}  // namespace epmap::sim
