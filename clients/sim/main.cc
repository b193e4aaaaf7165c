// epmap-sim: synthetic worlds with exact ground truth (clients/sim/README.md).
//   epmap-sim record  --scenario NAME --out DIR [--frames N] [--seed S] [--size WxH] [--force]
//   epmap-sim publish --scenario NAME --domain N [--rate HZ] [--frames N | --max-frames N]
//                     [--seed S] [--size WxH]
//   epmap-sim list
// Scenario knobs for both: --encoder-noise-scale X, --flicker-scale X, --no-noise, and for
// building --reverse, --disparity-every-frame, --walker, --first-frame N.
// Exit codes: 0 done, 2 bad input (the message says why), 1 failure while running.

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <stdexcept>

#include "clients/sim/publish.h"
#include "clients/sim/record.h"
#include "clients/sim/scenario.h"

namespace {

std::atomic<bool> g_stop{false};

void OnSignal(int) {
  g_stop = true;
}

struct CommonFlags {
  std::string scenario;
  int frames = 0;
  uint64_t seed = 1;
  std::string size;
  double encoder_noise_scale = 1;
  double odometry_scale_error = 0;
  double flicker_scale = 1;
  bool no_noise = false;
  bool reverse = false;
  int passes = 1;
  std::string route = "corridors";
  bool disparity_every_frame = false;
  bool walker = false;
  int first_frame = 0;
  int supersample = 0;

  void AddTo(CLI::App* app) {
    std::string names;
    for (const auto& n : epmap::sim::ScenarioNames()) names += (names.empty() ? "" : ", ") + n;
    app->add_option("--scenario", scenario, "world to generate: " + names)->required();
    app->add_option("--frames", frames, "number of stereo frames (default: the scenario's)");
    app->add_option("--seed", seed, "random seed (same seed, same bytes)");
    app->add_option("--size", size, "image size WxH (default: the scenario's, e.g. 640x480)");
    app->add_option("--encoder-noise-scale", encoder_noise_scale,
                    "multiplies the encoder and odometry noise (1 = default)");
    app->add_option("--flicker-scale", flicker_scale,
                    "multiplies the illumination flicker (1 = default)");
    app->add_flag("--no-noise", no_noise,
                  "exact encoders, true chain = URDF, no image noise or flicker");
    app->add_option("--odometry-scale-error", odometry_scale_error,
                    "building: both wheels travel this share more than the odometry counts "
                    "(0.01 = 1 %; default 0)");
    app->add_flag("--reverse", reverse, "building: drive the route in the reverse direction");
    app->add_option("--passes", passes,
                    "building: drive the route this many times, turning back at each end (a "
                    "long run; default 1)");
    app->add_option("--route", route,
                    "building: corridors (default: two rooms, both corridors) or rooms (corridor "
                    "H, stepping into seven of the eight rooms)");
    app->add_flag("--disparity-every-frame", disparity_every_frame,
                  "building: true disparity for every frame, not only at the stops");
    app->add_flag("--walker", walker,
                  "building: a person walks to and fro along the first corridor (true masks "
                  "and positions recorded)");
    app->add_option("--first-frame", first_frame,
                    "building: start at this frame of the route (e.g. 250: entering the corridor)");
    app->add_option("--supersample", supersample,
                    "light samples per pixel along each axis, odd: 3 gives silhouettes their "
                    "sub-pixel position in the grey levels, as a real sensor does (default: 1)");
  }

  epmap::sim::ScenarioOptions Options() const {
    epmap::sim::ScenarioOptions o;
    o.name = scenario;
    o.frames = frames;
    o.seed = seed;
    if (!size.empty()) std::tie(o.width, o.height) = epmap::sim::ParseImageSize(size);
    o.encoder_noise_scale = encoder_noise_scale;
    o.flicker_scale = flicker_scale;
    o.noise = !no_noise;
    o.reverse = reverse;
    o.passes = passes;
    o.odometry_scale_error = odometry_scale_error;
    o.route = route;
    o.disparity_every_frame = disparity_every_frame;
    o.walker = walker;
    o.first_frame = first_frame;
    o.supersample = supersample;
    return o;
  }
};

int Record(const CommonFlags& flags, const std::string& out, bool force) {
  namespace fs = std::filesystem;
  // Refuse before any work is done.
  if (fs::exists(out) && (!fs::is_directory(out) || !fs::is_empty(out)) && !force) {
    throw std::invalid_argument("output folder " + out +
                                " exists and is not empty (use --force to replace its content)");
  }
  const auto scenario = epmap::sim::MakeScenario(flags.Options());
  std::cerr << "epmap-sim: recording " << scenario->Describe() << " into " << out << "\n";
  int last_tenth = -1;
  epmap::sim::Record(*scenario, out, force, [&](int done, int total) {
    if (scenario->frame_count() == 0) return;
    const int tenth = 10 * done / total;
    if (tenth != last_tenth) {
      std::cerr << "  " << done << "/" << total << " frames\n";
      last_tenth = tenth;
    }
  });
  std::cerr << "epmap-sim: done: " << out << "\n";
  return 0;
}

int Publish(const CommonFlags& flags, uint32_t domain, double rate, double wait_s, int max_frames) {
  const auto scenario = epmap::sim::MakeScenario(flags.Options());
  epmap::sim::PublishOptions o;
  o.domain_id = domain;
  o.rate_hz = rate;
  o.max_frames = max_frames;
  o.wait_for_readers = std::chrono::milliseconds(static_cast<int64_t>(wait_s * 1000));
  o.stop_requested = [] { return g_stop.load(); };
  o.log = [](const std::string& m) { std::cerr << "epmap-sim: " << m << "\n"; };
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::cerr << "epmap-sim: publishing " << scenario->Describe() << " on DDS domain " << domain
            << "\n";
  const auto report = epmap::sim::Publish(*scenario, o);
  std::cerr << "epmap-sim: sent " << report.frames_sent
            << (scenario->frame_count() > 0 ? " stereo frames" : " eye-hand paths") << " in "
            << report.seconds << " s\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("epmap-sim: synthetic stereo-head and mobile-robot worlds with exact ground truth");
  app.require_subcommand(1);

  CommonFlags record_flags, publish_flags;
  std::string out;
  bool force = false;
  auto* record = app.add_subcommand("record", "write a dataset (EuRoC layout + ground truth)");
  record_flags.AddTo(record);
  record->add_option("--out", out, "output folder")->required();
  record->add_flag("--force", force, "replace the content of a non-empty output folder");

  uint32_t domain = 0;
  double rate = 0;
  double wait_s = 10;
  int max_frames = 0;
  auto* publish = app.add_subcommand("publish", "send the frames over DDS in real time");
  publish_flags.AddTo(publish);
  publish->add_option("--domain", domain, "DDS domain id")->required()->check(CLI::Range(0, 232));
  publish->add_option("--rate", rate, "frames per second (default: the scenario's rate)")
      ->check(CLI::NonNegativeNumber);
  publish->add_option("--wait", wait_s, "seconds to wait for readers before sending (default 10)")
      ->check(CLI::NonNegativeNumber);

  publish
      ->add_option("--max-frames", max_frames,
                   "stop after this many frames, or at the scenario's end if it has fewer (unlike "
                   "--frames, more than the scenario has is not an error; 0: all)")
      ->check(CLI::NonNegativeNumber);

  auto* list = app.add_subcommand("list", "list the scenarios");

  CLI11_PARSE(app, argc, argv);
  try {
    if (*record) return Record(record_flags, out, force);
    if (*publish) return Publish(publish_flags, domain, rate, wait_s, max_frames);
    if (*list) {
      for (const auto& name : epmap::sim::ScenarioNames()) std::cout << name << "\n";
      return 0;
    }
  } catch (const std::invalid_argument& e) {
    std::cerr << "epmap-sim: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "epmap-sim: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
