#pragma once
// What every epmapctl subcommand shares: the server address, the call deadline, the channel
// (with receive limits raised for large maps) and uniform error reporting.

#include <grpcpp/grpcpp.h>

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace epmap::ctl {

struct ClientOptions {
  std::string server = "127.0.0.1:50051";
  double timeout_s = 30.0;
  int exit_code = 0;

  std::shared_ptr<grpc::Channel> Channel() const;
  // A context with the deadline applied (plus what the server is asked to wait, in ms).
  std::unique_ptr<grpc::ClientContext> Context(uint32_t server_wait_ms = 0) const;
  // Prints "epmapctl: <CODE>: <message>" and returns 1 for a failed call.
  int Fail(const grpc::Status& status) const;
};

// --newer-than / --wait-ms of the maps commands (pmap, grid, pose): wait for the maps after
// the ones a script already has (they change at key frames).
struct MapsWait {
  int64_t newer_than_ns = 0;
  uint32_t wait_ms = 0;
  void AddOptions(CLI::App* command);
  template <typename Request>
  void Apply(Request* request) const {
    request->set_newer_than_ns(newer_than_ns);
    request->set_wait_ms(wait_ms);
  }
};

// --region / --around-robot of the maps commands (pmap, grid): a window of the map, a box of
// the world frame or a square centred on the robot, as a local planner asks for it.
struct MapWindow {
  std::vector<double> region;  // min_x, min_y, max_x, max_y (m)
  std::optional<double> around_robot_m;
  // what_is_kept: what the window holds, for the help ("the cells", "the segments with some
  // part").
  void AddOptions(CLI::App* command, const std::string& what_is_kept);
  template <typename Request>
  void Apply(Request* request) const {
    if (!region.empty()) {
      auto* box = request->mutable_region();
      box->set_min_x(region[0]);
      box->set_min_y(region[1]);
      box->set_max_x(region[2]);
      box->set_max_y(region[3]);
    }
    if (around_robot_m) request->set_around_robot_m(*around_robot_m);
  }
};

// What the maps commands add to their summary line while the service serves maps it resumed
// after a restart that no key frame has confirmed yet.
inline constexpr const char* kResumedNote =
    ", as saved before the service restarted (not yet confirmed by a key frame)";

// Subcommands register a setup function that adds themselves to the app.
using CommandSetup = std::function<void(CLI::App& app, ClientOptions& options)>;
std::vector<CommandSetup>& CommandSetups();
struct CommandRegistrar {
  explicit CommandRegistrar(CommandSetup setup) { CommandSetups().push_back(std::move(setup)); }
};

// Writes an image file chosen by extension; throws std::runtime_error on failure.
void WriteImageFile(const std::string& path, const cv::Mat& image);

}  // namespace epmap::ctl

#define EPMAP_CTL_COMMAND(ident, setup) \
  static ::epmap::ctl::CommandRegistrar ident##_registrar(setup)
