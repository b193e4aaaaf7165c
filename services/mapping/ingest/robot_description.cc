#include "services/mapping/ingest/robot_description.h"

#include <epmap_dds/StringPubSubTypes.h>
#include <unistd.h>

#include <condition_variable>
#include <fstream>
#include <mutex>
#include <optional>
#include <stdexcept>

#include "common/dds/endpoints.h"
#include "common/dds/participant.h"

namespace epmap::mapping {

namespace {
// Large robots' URDFs (meshes are referenced, not embedded) are well under this.
constexpr uint32_t kMaxDescriptionBytes = 16u << 20;
}  // namespace

void FetchRobotDescription(uint32_t domain, const std::string& topic,
                           std::chrono::milliseconds wait, const std::filesystem::path& out) {
  std::mutex mutex;
  std::condition_variable arrived;
  std::optional<std::string> text;
  {
    dds::Participant participant(domain, "epmapd-robot-description");
    // Transient local and reliable, as robot_state_publisher offers it: the latched sample
    // reaches a reader that joins after it was written.
    dds::Reader<std_msgs::msg::String, std_msgs::msg::StringPubSubType> reader(
        participant, topic,
        [&](std_msgs::msg::String&& msg) {
          std::lock_guard lock(mutex);
          text = std::move(msg.data());
          arrived.notify_all();
        },
        kMaxDescriptionBytes, 1, dds::Durability::kTransientLocal);
    std::unique_lock lock(mutex);
    arrived.wait_for(lock, wait, [&] { return text.has_value(); });
    if (!text) {
      const bool oversized = reader.counters().oversized > 0;
      throw std::runtime_error(
          oversized ? "the robot description on " + topic + " is larger than 16 MiB"
                    : "no robot description on " + topic + " (domain " + std::to_string(domain) +
                          ") within " + std::to_string(wait.count()) +
                          " ms: is robot_state_publisher running? (or give robot.urdf)");
    }
  }  // the reader and its participant go before the text is used
  if (text->find("<robot") == std::string::npos) {
    throw std::runtime_error("the robot description on " + topic + " (" +
                             std::to_string(text->size()) + " bytes) is not a URDF <robot>");
  }
  std::filesystem::create_directories(out.parent_path());
  std::ofstream file(out, std::ios::trunc);
  file << *text;
  if (!file.flush())
    throw std::runtime_error("cannot write the robot description to " + out.string());
}

std::filesystem::path RobotDescriptionPath(const std::string& state_dir) {
  if (!state_dir.empty()) return std::filesystem::path(state_dir) / "robot_description.urdf";
  return std::filesystem::temp_directory_path() /
         ("epmapd-" + std::to_string(::getpid()) + "-robot_description.urdf");
}

}  // namespace epmap::mapping
