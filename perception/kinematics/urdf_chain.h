#pragma once
// The internal model's analytic half (paper 000, Sec. III-IV: T : R^I -> SE(3)): forward
// kinematics of the chain from the URDF's root link to each camera's optical frame, computed
// with orocos-KDL on a tree loaded through the URDF parser (kdl_parser).

#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace epmap::kinematics {

// The links of the two cameras' optical frames (x right, y down, z forward). The defaults are
// the dataset layout's names; a robot's own URDF usually has others (e.g.
// "left_camera_optical_frame"), which epmapd takes from robot.left_camera_link / right_camera_link.
struct CameraLinks {
  std::string left = "cam0_optical";
  std::string right = "cam1_optical";
};

class UrdfChain {
 public:
  // Parses the URDF and extracts the chains root -> links.left (required) and root ->
  // links.right (optional). Throws std::runtime_error with the reason on an unparsable URDF
  // or a missing left camera link (the message lists the links that look like optical frames).
  static UrdfChain FromFile(const std::filesystem::path& urdf_path, const CameraLinks& links = {});
  static UrdfChain FromString(const std::string& urdf_xml, const CameraLinks& links = {});

  UrdfChain(UrdfChain&&) noexcept;
  UrdfChain& operator=(UrdfChain&&) noexcept;
  ~UrdfChain();

  const std::string& root_link() const;
  const CameraLinks& camera_links() const;
  // The movable joints on the way to the left camera (and the right one), in chain order.
  const std::vector<std::string>& joint_names() const;
  bool has_cam1() const;

  // Binds the order of externally provided joint values (e.g. joints0's columns). Every
  // chain joint must be present; extra names are ignored. Throws std::invalid_argument
  // listing the chain joints that are missing.
  void BindJointOrder(const std::vector<std::string>& names);

  // T_root_cam0 (and T_root_cam1: the left and right camera links) for joint values in the bound
  // order (or in joint_names() order if nothing was bound). Throws std::invalid_argument on a wrong
  // count or NaN.
  Eigen::Isometry3d Cam0Pose(const std::vector<double>& joints) const;
  Eigen::Isometry3d Cam1Pose(const std::vector<double>& joints) const;
  // Whether the URDF has a link of that name.
  bool HasLink(const std::string& link) const;
  // The root and the links joined to it by fixed joints only, in tree order: the frames an
  // odometry source may move with a pose that needs no joint reading (base_footprint, base_link).
  std::vector<std::string> LinksFixedToRoot() const;
  // Pose of any link of the tree. Throws std::invalid_argument if the link is missing or a
  // movable joint on the way to it is not on a camera chain (its value is not read).
  Eigen::Isometry3d LinkPose(const std::string& link, const std::vector<double>& joints) const;

 private:
  struct Impl;
  explicit UrdfChain(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace epmap::kinematics
