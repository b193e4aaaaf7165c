#pragma once
// The robot's URDF as ROS 2's robot_state_publisher latches it on /robot_description
// (std_msgs/String, reliable + transient local), for a robot whose URDF is not a file beside
// epmapd. Fetched once at start; the rest of the service reads it from the file it is kept in.

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>

namespace epmap::mapping {

// Waits up to `wait` on DDS domain `domain` for the description latched on `topic` (e.g.
// "rt/robot_description") and writes it to `out`. Throws std::runtime_error with the reason when
// nothing arrives in time, or the text is empty or not a <robot> document.
void FetchRobotDescription(uint32_t domain, const std::string& topic,
                           std::chrono::milliseconds wait, const std::filesystem::path& out);

// Where a fetched description is kept: <state_dir>/robot_description.urdf (durable: the chain a
// calibration was made with stays readable), or a per-process file in the temp folder.
std::filesystem::path RobotDescriptionPath(const std::string& state_dir);

}  // namespace epmap::mapping
