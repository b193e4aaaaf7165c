// epmapd: the epmap mapping service.
//   epmapd --listen 127.0.0.1:PORT --domain N [--config FILE] [--num-disparities N] ...
// Stops cleanly on SIGINT or SIGTERM.

#include <signal.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "services/mapping/config/camera_chain.h"
#include "services/mapping/config/service_config.h"
#include "services/mapping/ingest/robot_description.h"
#include "services/mapping/service.h"

int main(int argc, char** argv) {
  using epmap::mapping::ServiceConfig;
  CLI::App app("epmapd: expected-perception stereo mapping service (DDS in, gRPC out)");
  std::string config_path;
  std::string listen, mode, urdf, urdf_topic, state_dir, log_level;
  int64_t domain = -1;
  int num_disparities = 0;
  bool print_config = false;
  bool check_robot = false;
  app.add_option("--config", config_path, "YAML config (deploy/epmapd.yaml documents every key)")
      ->check(CLI::ExistingFile);
  app.add_option("--listen", listen, "gRPC address host:port (overrides api.listen)");
  app.add_option("--domain", domain, "DDS domain id 0..232 (overrides dds.domain)");
  app.add_option("--num-disparities", num_disparities,
                 "SGBM disparity range, a multiple of 16 (overrides stereo.num_disparities)");
  app.add_option("--mode", mode, "auto | head | static | mobile-base (overrides robot.mode)");
  app.add_option("--urdf", urdf, "kinematic chain URDF (overrides robot.urdf)");
  app.add_option("--urdf-topic", urdf_topic,
                 "take the URDF from this latched topic at start, e.g. rt/robot_description "
                 "(robot_state_publisher's; overrides robot.urdf_topic)");
  app.add_option("--state-dir", state_dir, "durable state folder (overrides state.dir)");
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error");
  app.add_flag("--print-config", print_config, "print the effective configuration and exit");
  app.add_flag("--check-robot", check_robot,
               "load the URDF with the configured camera links, print the chain (root, cameras, "
               "joints and limits, poses at zero joints) and exit: 0 if it loads, 1 if not");
  CLI11_PARSE(app, argc, argv);

  ServiceConfig config;
  try {
    if (!config_path.empty()) config = epmap::mapping::LoadServiceConfig(config_path);
    if (!listen.empty()) config.listen = listen;
    if (domain >= 0) config.domain = static_cast<uint32_t>(domain);
    if (domain < -1 || domain > 232) throw std::invalid_argument("--domain must be 0..232");
    if (num_disparities != 0) config.sgbm.num_disparities = num_disparities;
    if (!mode.empty()) config.mode = mode;
    // A file or a topic: the one given on the command line wins over the config's other.
    if (!urdf.empty()) {
      config.urdf = urdf;
      config.urdf_topic.clear();
    }
    if (!urdf_topic.empty()) {
      config.urdf_topic = urdf_topic;
      config.urdf.clear();
    }
    if (!state_dir.empty()) config.state_dir = state_dir;
    if (!log_level.empty()) config.log_level = log_level;
    config.Validate();
  } catch (const std::exception& e) {
    std::cerr << "epmapd: configuration error: " << e.what() << "\n";
    return 2;
  }
  if (print_config) {
    std::cout << epmap::mapping::ToYaml(config);
    return 0;
  }
  if (!config.urdf_topic.empty()) {
    // The rest of the service reads the URDF from a file: keep the fetched one in the state
    // folder (or the temp folder) and point robot.urdf at it.
    const auto kept = epmap::mapping::RobotDescriptionPath(config.state_dir);
    try {
      epmap::mapping::FetchRobotDescription(
          config.domain, config.urdf_topic,
          std::chrono::duration_cast<std::chrono::milliseconds>(
              std::chrono::nanoseconds(config.urdf_topic_wait_ns)),
          kept);
    } catch (const std::exception& e) {
      std::cerr << "epmapd: " << e.what() << "\n";
      return 1;
    }
    if (check_robot) {
      std::cout << "robot description from " << config.urdf_topic << ", kept in " << kept.string()
                << "\n";
    } else {
      spdlog::info("robot description from {} kept in {}", config.urdf_topic, kept.string());
    }
    config.urdf = kept.string();
    config.urdf_topic.clear();  // fetched: from here on the URDF is that file
  }
  if (check_robot) {
    try {
      std::cout << epmap::mapping::DescribeCameraChain(config);
    } catch (const std::exception& e) {
      std::cerr << "epmapd: " << e.what() << "\n";
      return 1;
    }
    return 0;
  }
  spdlog::set_level(spdlog::level::from_str(config.log_level));

  // Every thread started from here on inherits the blocked signals; main waits for them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  try {
    epmap::mapping::MappingService service(config);
    int signal_number = 0;
    sigwait(&signals, &signal_number);
    spdlog::info("received {}", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
    service.Shutdown();
  } catch (const std::exception& e) {
    std::cerr << "epmapd: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
