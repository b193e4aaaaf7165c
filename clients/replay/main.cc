// epmap-replay: publishes a dataset over DDS (ROS 2 topics) and exits.
//   epmap-replay PATH --domain N [--rate HZ]
// PATH is an EuRoC/ASL sequence (DIR with mav0/) or a stereo-pair folder (left.png, right.png,
// pair.yaml). It waits until readers have matched before sending.

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "clients/replay/dataset_publisher.h"
#include "common/dataset/dataset.h"

int main(int argc, char** argv) {
  CLI::App app("epmap-replay: publish a recorded dataset over DDS, then exit");
  std::string path;
  epmap::replay::ReplayOptions options;
  int64_t domain = 0;
  app.add_option("path", path, "dataset folder (sequence with mav0/, or stereo pair)")->required();
  app.add_option("--domain", domain, "DDS domain id 0..232")->check(CLI::Range(0, 232));
  app.add_option("--rate", options.rate_hz, "frames per second (default: the dataset's own)")
      ->check(CLI::PositiveNumber);
  app.add_option("--wait", options.wait_for_reader_s, "seconds to wait for readers to match")
      ->capture_default_str();
  app.add_flag("--restamp", options.restamp, "stamp messages with the wall clock");
  app.add_option("--loop-for", options.loop_for_s,
                 "replay again and again for this many seconds (restamps)");
  app.add_option("--preload", options.preload_frames,
                 "decode up to this many frames into memory before sending");
  app.add_option("--left-image-topic", options.topics.left_image)->capture_default_str();
  app.add_option("--right-image-topic", options.topics.right_image)->capture_default_str();
  app.add_option("--left-info-topic", options.topics.left_info)->capture_default_str();
  app.add_option("--right-info-topic", options.topics.right_info)->capture_default_str();
  app.add_option("--joints-topic", options.topics.joints)->capture_default_str();
  app.add_option("--odom-topic", options.topics.odom)->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  options.domain = static_cast<uint32_t>(domain);
  try {
    const auto dataset = epmap::dataset::Load(path);
    std::cerr << "epmap-replay: " << dataset.frames.size() << " stereo frames"
              << (dataset.joints.empty() ? "" : ", joint states")
              << (dataset.odometry.empty() ? "" : ", odometry") << " from " << path
              << "; waiting for readers on domain " << options.domain << "\n";
    const auto report = epmap::replay::Replay(dataset, options);
    std::cerr << "epmap-replay: published " << report.frames << " frames, " << report.joint_states
              << " joint states, " << report.odometry << " odometry in " << report.seconds
              << " s\n";
  } catch (const std::exception& e) {
    std::cerr << "epmap-replay: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
