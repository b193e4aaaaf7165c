#pragma once
// Default ROS 2 topics (wire names, "rt/" prefixed) of the service; every one is renamable in
// epmapd's config and in the publishers' flags.

#include <string>

namespace epmap::dds {

struct TopicNames {
  std::string left_image = "rt/stereo/left/image_raw";
  std::string right_image = "rt/stereo/right/image_raw";
  std::string left_info = "rt/stereo/left/camera_info";
  std::string right_info = "rt/stereo/right/camera_info";
  std::string joints = "rt/joint_states";
  std::string odom = "rt/odom";
  // The URDF as robot_state_publisher latches it (std_msgs/String, transient local): epmap-sim
  // publishes it, epmapd reads it with --urdf-topic.
  std::string robot_description = "rt/robot_description";
  std::string eye_hand_samples = "rt/epmap/eye_hand_samples";
  // What epmapd publishes in mobile-base mode (empty: not published): the occupancy grid as
  // nav_msgs/OccupancyGrid (transient local, as map_server), map -> odom on tf, and the
  // perceptual map as visualization_msgs/MarkerArray for RViz.
  std::string map = "rt/map";
  std::string tf = "rt/tf";
  std::string perceptual_map = "rt/epmap/perceptual_map";
  // What epmapd publishes for every processed frame, in any mode, while a reader listens (no
  // reader: nothing is converted): the EP disparity map as stereo_msgs/DisparityImage (as
  // stereo_image_proc's `disparity`) and the unexpected-motion mask as a mono8 image.
  std::string disparity = "rt/epmap/disparity";
  std::string unexpected_mask = "rt/epmap/unexpected_mask";
};

}  // namespace epmap::dds
