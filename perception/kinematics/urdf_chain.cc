#include "perception/kinematics/urdf_chain.h"

#include <urdf_parser/urdf_parser.h>
#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

namespace epmap::kinematics {

namespace {

Eigen::Isometry3d ToEigen(const KDL::Frame& f) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = f.M(r, c);
    T.translation()(r) = f.p(r);
  }
  return T;
}
}  // namespace

struct UrdfChain::Impl {
  KDL::Tree tree;
  std::string root;
  CameraLinks links;
  std::vector<std::string> joint_names;  // union of the movable joints of the camera chains
  bool has_cam1 = false;
  // For each bound input position, the index into joint_names (or -1 if unused).
  std::vector<int> input_to_joint;
  bool bound = false;

  struct ChainInfo {
    KDL::Chain chain;
    std::vector<int> joint_index;  // chain's movable joint i -> index into joint_names
  };
  // The camera chains, extracted once at load time (read-only afterwards: thread-safe).
  std::map<std::string, ChainInfo> chains;

  ChainInfo Chain(const std::string& link) const {
    if (auto it = chains.find(link); it != chains.end()) return it->second;
    ChainInfo info;
    if (!tree.getChain(root, link, info.chain)) {
      throw std::invalid_argument("URDF has no chain from '" + root + "' to '" + link + "'");
    }
    for (const auto& seg : info.chain.segments) {
      if (seg.getJoint().getType() == KDL::Joint::None) continue;
      const std::string& name = seg.getJoint().getName();
      int idx = -1;
      for (size_t i = 0; i < joint_names.size(); ++i) {
        if (joint_names[i] == name) idx = static_cast<int>(i);
      }
      if (idx < 0) {
        throw std::invalid_argument("joint '" + name + "' leads to '" + link +
                                    "' but is not on a camera chain");
      }
      info.joint_index.push_back(idx);
    }
    return info;
  }

  std::vector<double> Reorder(const std::vector<double>& input) const {
    std::vector<double> values(joint_names.size(), 0.0);
    if (!bound) {
      if (input.size() != joint_names.size()) {
        throw std::invalid_argument("expected " + std::to_string(joint_names.size()) +
                                    " joint values, got " + std::to_string(input.size()));
      }
      values = input;
    } else {
      if (input.size() != input_to_joint.size()) {
        throw std::invalid_argument("expected " + std::to_string(input_to_joint.size()) +
                                    " joint values, got " + std::to_string(input.size()));
      }
      for (size_t i = 0; i < input.size(); ++i) {
        if (input_to_joint[i] >= 0) values[static_cast<size_t>(input_to_joint[i])] = input[i];
      }
    }
    for (double v : values) {
      if (!std::isfinite(v)) throw std::invalid_argument("joint value is not finite");
    }
    return values;
  }

  Eigen::Isometry3d Pose(const std::string& link, const std::vector<double>& input) const {
    const ChainInfo info = Chain(link);
    const std::vector<double> values = Reorder(input);
    KDL::JntArray q(info.chain.getNrOfJoints());
    for (size_t i = 0; i < info.joint_index.size(); ++i) {
      q(static_cast<unsigned>(i)) = values[static_cast<size_t>(info.joint_index[i])];
    }
    KDL::ChainFkSolverPos_recursive fk(info.chain);
    KDL::Frame frame;
    if (fk.JntToCart(q, frame) < 0) throw std::runtime_error("KDL forward kinematics failed");
    return ToEigen(frame);
  }
};

UrdfChain::UrdfChain(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
UrdfChain::UrdfChain(UrdfChain&&) noexcept = default;
UrdfChain& UrdfChain::operator=(UrdfChain&&) noexcept = default;
UrdfChain::~UrdfChain() = default;

UrdfChain UrdfChain::FromFile(const std::filesystem::path& urdf_path, const CameraLinks& links) {
  std::ifstream in(urdf_path);
  if (!in) throw std::runtime_error("cannot open URDF " + urdf_path.string());
  std::stringstream text;
  text << in.rdbuf();
  try {
    return FromString(text.str(), links);
  } catch (const std::exception& e) {
    throw std::runtime_error(urdf_path.string() + ": " + e.what());
  }
}

UrdfChain UrdfChain::FromString(const std::string& urdf_xml, const CameraLinks& links) {
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_xml);
  if (!model) throw std::runtime_error("the URDF does not parse");
  auto impl = std::make_unique<Impl>();
  if (!kdl_parser::treeFromUrdfModel(*model, impl->tree)) {
    throw std::runtime_error("the URDF cannot be turned into a KDL tree");
  }
  impl->root = impl->tree.getRootSegment()->first;
  impl->links = links;
  const auto& segments = impl->tree.getSegments();
  if (segments.find(links.left) == segments.end()) {
    // Name the candidates: a robot's URDF names its optical frames its own way.
    std::string optical;
    for (const auto& [name, segment] : segments) {
      if (name.find("optical") == std::string::npos) continue;
      optical += (optical.empty() ? "" : ", ") + name;
    }
    throw std::runtime_error("the URDF has no link named '" + links.left + "'" +
                             (optical.empty()
                                  ? std::string()
                                  : " (links that look like optical frames: " + optical + ")"));
  }
  impl->has_cam1 = segments.find(links.right) != segments.end();
  for (const std::string& cam : {links.left, links.right}) {
    if (cam == links.right && !impl->has_cam1) continue;
    KDL::Chain chain;
    impl->tree.getChain(impl->root, cam, chain);
    for (const auto& seg : chain.segments) {
      if (seg.getJoint().getType() == KDL::Joint::None) continue;
      const std::string& name = seg.getJoint().getName();
      if (std::find(impl->joint_names.begin(), impl->joint_names.end(), name) ==
          impl->joint_names.end()) {
        impl->joint_names.push_back(name);
      }
    }
  }
  impl->chains.emplace(links.left, impl->Chain(links.left));
  if (impl->has_cam1) impl->chains.emplace(links.right, impl->Chain(links.right));
  return UrdfChain(std::move(impl));
}

const std::string& UrdfChain::root_link() const {
  return impl_->root;
}
const CameraLinks& UrdfChain::camera_links() const {
  return impl_->links;
}
const std::vector<std::string>& UrdfChain::joint_names() const {
  return impl_->joint_names;
}
bool UrdfChain::has_cam1() const {
  return impl_->has_cam1;
}

void UrdfChain::BindJointOrder(const std::vector<std::string>& names) {
  std::vector<int> mapping(names.size(), -1);
  std::vector<bool> found(impl_->joint_names.size(), false);
  for (size_t i = 0; i < names.size(); ++i) {
    for (size_t j = 0; j < impl_->joint_names.size(); ++j) {
      if (names[i] == impl_->joint_names[j]) {
        mapping[i] = static_cast<int>(j);
        found[j] = true;
      }
    }
  }
  std::string missing;
  for (size_t j = 0; j < found.size(); ++j) {
    if (!found[j]) missing += (missing.empty() ? "" : ", ") + impl_->joint_names[j];
  }
  if (!missing.empty()) {
    throw std::invalid_argument("joint readings lack the URDF chain joints: " + missing);
  }
  impl_->input_to_joint = std::move(mapping);
  impl_->bound = true;
}

Eigen::Isometry3d UrdfChain::Cam0Pose(const std::vector<double>& joints) const {
  return impl_->Pose(impl_->links.left, joints);
}

Eigen::Isometry3d UrdfChain::Cam1Pose(const std::vector<double>& joints) const {
  if (!impl_->has_cam1) {
    throw std::invalid_argument("the URDF has no link named '" + impl_->links.right + "'");
  }
  return impl_->Pose(impl_->links.right, joints);
}

bool UrdfChain::HasLink(const std::string& link) const {
  return impl_->tree.getSegments().count(link) > 0;
}

std::vector<std::string> UrdfChain::LinksFixedToRoot() const {
  std::vector<std::string> links;
  std::vector<KDL::SegmentMap::const_iterator> open{impl_->tree.getRootSegment()};
  while (!open.empty()) {
    const auto element = open.back();
    open.pop_back();
    links.push_back(element->first);
    const auto& children = GetTreeElementChildren(element->second);
    for (auto child = children.rbegin(); child != children.rend(); ++child) {
      if (GetTreeElementSegment((*child)->second).getJoint().getType() == KDL::Joint::None) {
        open.push_back(*child);
      }
    }
  }
  return links;
}

Eigen::Isometry3d UrdfChain::LinkPose(const std::string& link,
                                      const std::vector<double>& joints) const {
  return impl_->Pose(link, joints);
}

}  // namespace epmap::kinematics
