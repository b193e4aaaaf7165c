// epmap-bench sim: what the synthetic worlds (clients/sim) cost and how real they look.
//   render    one 640x480 stereo frame of `head` with all its ground truth, on one core, beside
//             yardsticks measured in the same run: copying the two images, cv::remap of both
//             (a frame's warp) and PNG-encoding both (what `record` adds per frame)
//   publish   `epmap-sim publish` (run as a process) against a DDS reader here: frames per
//             second received at 30 Hz for ~10 s and as fast as possible, and the publisher's
//             CPU time per frame
//   realism   StereoSGBM (perception/stereo, default parameters) on rendered pairs vs their
//             ground truth, beside the same matcher on the real pairs of ../shared/data
// Prints one JSON object per case.

#include <epmap_dds/ImagePubSubTypes.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <vector>

#include "bench/epmap_bench/command_registry.h"
#include "bench/epmap_bench/summary.h"
#include "clients/sim/scenario.h"
#include "common/dataset/dataset.h"
#include "common/dds/endpoints.h"
#include "common/dds/participant.h"
#include "common/dds/topics.h"
#include "perception/stereo/metrics.h"
#include "perception/stereo/sgbm.h"

namespace {

namespace fs = std::filesystem;
using namespace epmap::bench;
using epmap::sim::MakeScenario;
using epmap::sim::ScenarioOptions;

double ThreadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

double WallMs() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Times `fn` `n` times; returns {median thread-CPU ms, median wall ms}.
template <class Fn>
std::pair<double, double> Time(int n, Fn&& fn) {
  std::vector<double> cpu, wall;
  for (int i = 0; i < n; ++i) {
    const double c0 = ThreadCpuMs(), w0 = WallMs();
    fn(i);
    cpu.push_back(ThreadCpuMs() - c0);
    wall.push_back(WallMs() - w0);
  }
  return {Median(cpu), Median(wall)};
}

void RenderCase(int frames) {
  cv::setNumThreads(1);  // one core: OpenCV's own threads off too
  ScenarioOptions o;
  o.name = "head";
  const auto scenario = MakeScenario(o);
  const int n = std::min(frames, scenario->frame_count());
  const auto render = Time(n, [&](int i) {
    const auto f = scenario->Render(i * scenario->frame_count() / n);
    if (f.left.empty() || f.gt_disparity.empty()) std::abort();
  });
  const auto frame = scenario->Render(0);
  cv::Mat map_x(frame.left.size(), CV_32FC1), map_y(frame.left.size(), CV_32FC1);
  for (int y = 0; y < map_x.rows; ++y) {
    for (int x = 0; x < map_x.cols; ++x) {
      map_x.at<float>(y, x) = x - 20.5F + 0.01F * y;  // a generic sub-pixel warp
      map_y.at<float>(y, x) = y + 0.3F;
    }
  }
  cv::Mat a, b;
  const auto copy = Time(n, [&](int) {
    a = frame.left.clone();
    b = frame.right.clone();
  });
  const auto remap = Time(n, [&](int) {
    cv::remap(frame.left, a, map_x, map_y, cv::INTER_LINEAR);
    cv::remap(frame.right, b, map_x, map_y, cv::INTER_LINEAR);
  });
  std::vector<uchar> buf;
  const auto png = Time(std::min(n, 20), [&](int) {
    cv::imencode(".png", frame.left, buf);
    cv::imencode(".png", frame.right, buf);
  });
  std::printf(
      "{\"command\":\"sim\",\"case\":\"render_head_640x480\",\"frames\":%d,"
      "\"render_ms_median_cpu\":%.2f,\"render_ms_median_wall\":%.2f,"
      "\"baseline_copy_two_images_ms\":%.3f,\"baseline_remap_two_images_ms\":%.2f,"
      "\"baseline_png_encode_two_images_ms\":%.2f,\"render_over_remap\":%.1f,"
      "\"target_ms\":30}\n",
      n, render.first, render.second, copy.first, remap.first, png.first,
      render.first / remap.first);
  std::fflush(stdout);
}

// Runs `epmap-sim publish` (the real command, as its own process) for `frames` frames of head
// at `rate_hz` and counts what a reader in this process receives; the child's CPU time per
// frame says how many cores 30 Hz takes, whatever else the machine is doing.
void PublishCase(const fs::path& sim_binary, uint32_t domain, int frames, double rate_hz) {
  epmap::dds::Participant participant(domain, "epmap-bench-sim-reader");
  std::mutex mutex;
  std::vector<double> arrivals;
  std::atomic<int> bad{0};
  const epmap::dds::TopicNames topics;
  epmap::dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> reader(
      participant, topics.left_image,
      [&](sensor_msgs::msg::Image&& m) {
        if (m.width() != 640 || m.height() != 480 || m.data().size() != 640u * 480u * 3u) ++bad;
        std::lock_guard lock(mutex);
        arrivals.push_back(WallMs());
      },
      8u << 20, 30);
  // The publisher waits for a reader on each image topic.
  epmap::dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> right_reader(
      participant, topics.right_image, [](sensor_msgs::msg::Image&&) {}, 8u << 20, 30);

  std::vector<std::string> args = {sim_binary.string(),
                                   "publish",
                                   "--scenario",
                                   "head",
                                   "--domain",
                                   std::to_string(domain),
                                   "--frames",
                                   std::to_string(frames),
                                   "--rate",
                                   std::to_string(rate_hz)};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const double t0 = WallMs();
  if (posix_spawn(&pid, sim_binary.c_str(), &actions, nullptr, argv.data(), environ) != 0) {
    posix_spawn_file_actions_destroy(&actions);
    throw std::runtime_error("cannot run " + sim_binary.string());
  }
  posix_spawn_file_actions_destroy(&actions);
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  const double elapsed_s = (WallMs() - t0) / 1000.0;
  const double cpu_ms = usage.ru_utime.tv_sec * 1e3 + usage.ru_utime.tv_usec / 1e3 +
                        usage.ru_stime.tv_sec * 1e3 + usage.ru_stime.tv_usec / 1e3;
  std::lock_guard lock(mutex);
  const double span_s = arrivals.size() > 1 ? (arrivals.back() - arrivals.front()) / 1000.0 : 0.0;
  std::printf(
      "{\"command\":\"sim\",\"case\":\"publish_head_640x480\",\"rate_hz\":%.0f,"
      "\"exit_code\":%d,\"frames\":%d,\"frames_received\":%zu,\"malformed\":%d,"
      "\"received_fps\":%.2f,\"publisher_cpu_ms_per_frame\":%.1f,"
      "\"cores_for_30hz\":%.2f,\"process_seconds\":%.1f,\"baseline_target_fps\":30}\n",
      rate_hz, WIFEXITED(status) ? WEXITSTATUS(status) : -1, frames, arrivals.size(), bad.load(),
      span_s > 0 ? (arrivals.size() - 1) / span_s : 0.0, cpu_ms / frames,
      cpu_ms / frames * 30 / 1000, elapsed_s);
  std::fflush(stdout);
}

// Pixels with texture: local standard deviation of the grey image over SGBM's 5x5 block above
// `threshold` grey levels.
cv::Mat TexturedMask(const cv::Mat& image, double threshold) {
  cv::Mat grey, f, mean, sq_mean;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else {
    grey = image;
  }
  grey.convertTo(f, CV_32F);
  cv::blur(f, mean, cv::Size(5, 5));
  cv::blur(f.mul(f), sq_mean, cv::Size(5, 5));
  cv::Mat var = sq_mean - mean.mul(mean);
  return var > threshold * threshold;
}

struct Score {
  epmap::stereo::DisparityScore all, textured;
  void Add(const cv::Mat& disp, const cv::Mat& truth, const cv::Mat& left) {
    for (auto [total, mask] :
         {std::pair(&all, cv::Mat()), std::pair(&textured, TexturedMask(left, 5.0))}) {
      const auto s = epmap::stereo::ScoreDisparity(disp, truth, 2.0, mask);
      total->gt_pixels += s.gt_pixels;
      total->filled += s.filled;
      total->bad_filled += s.bad_filled;
    }
  }
  void Print(const std::string& name, const std::string& source, int frames, int num_disp) const {
    std::printf(
        "{\"command\":\"sim\",\"case\":\"realism\",\"pair\":\"%s\",\"source\":\"%s\",\"frames\":%d,"
        "\"num_disparities\":%d,\"bad2\":%.4f,\"bad2_over_filled\":%.4f,\"filled\":%.4f,"
        "\"textured_share\":%.3f,\"textured_bad2\":%.4f,\"textured_bad2_over_filled\":%.4f}\n",
        name.c_str(), source.c_str(), frames, num_disp, all.bad_counting_unknown(),
        all.bad_over_filled(), all.filled_share(),
        all.gt_pixels ? double(textured.gt_pixels) / all.gt_pixels : 0.0,
        textured.bad_counting_unknown(), textured.bad_over_filled());
    std::fflush(stdout);
  }
};

void RealismCase(int frames, const fs::path& shared_data) {
  for (const std::string name : {"head", "building"}) {
    ScenarioOptions o;
    o.name = name;
    const auto scenario = MakeScenario(o);
    epmap::stereo::SgbmParams params;
    params.num_disparities = scenario->num_disparities();
    const epmap::stereo::SgbmMatcher matcher(params);
    Score score;
    for (int k = 0; k < frames; ++k) {
      const auto f = scenario->Render(k * scenario->frame_count() / frames);
      score.Add(matcher.Compute(f.left, f.right), f.gt_disparity, f.left);
    }
    score.Print(name, "epmap-sim", frames, params.num_disparities);
  }
  const fs::path pairs = shared_data / "stereo-pairs";
  if (!fs::exists(pairs)) {
    std::cerr << "epmap-bench sim: " << pairs << " not found; real pairs skipped\n";
    return;
  }
  std::vector<fs::path> folders;
  for (const auto& e : fs::directory_iterator(pairs)) folders.push_back(e.path());
  std::sort(folders.begin(), folders.end());
  for (const auto& folder : folders) {
    if (!fs::exists(folder / "pair.yaml")) continue;
    const auto d = epmap::dataset::Load(folder);
    const cv::Mat truth = epmap::dataset::LoadGtDisparity(d, d.frames[0].stamp_ns);
    if (truth.empty()) continue;
    epmap::stereo::SgbmParams params;
    if (d.num_disparities > 0) params.num_disparities = d.num_disparities;
    const cv::Mat left = cv::imread(d.frames[0].left.string(), cv::IMREAD_UNCHANGED);
    const cv::Mat right = cv::imread(d.frames[0].right.string(), cv::IMREAD_UNCHANGED);
    Score score;
    score.Add(epmap::stereo::ComputeDisparity(left, right, params), truth, left);
    score.Print(folder.filename().string(), "real", 1, params.num_disparities);
  }
}

int Run(int argc, char** argv) {
  CLI::App app("synthetic worlds: render cost, publish rate, stereo realism", argv[0]);
  int frames = 60, publish_frames = 300, realism_frames = 10;
  uint32_t domain = static_cast<uint32_t>(::getpid() % 150) + 60;
  bool skip_publish = false, skip_realism = false;
  std::string shared = "../shared/data";
  app.add_option("--frames", frames, "frames timed for the render case");
  app.add_option("--publish-frames", publish_frames, "frames published at 30 Hz (300 = 10 s)");
  app.add_option("--realism-frames", realism_frames, "rendered pairs scored per scenario");
  app.add_option("--domain", domain, "DDS domain of the publish case");
  app.add_option("--shared-data", shared, "folder holding stereo-pairs/ (real reference pairs)");
  app.add_flag("--skip-publish", skip_publish, "leave out the publish cases");
  app.add_flag("--skip-realism", skip_realism, "leave out the realism cases");
  CLI11_PARSE(app, argc, argv);
  try {
    RenderCase(frames);
    if (!skip_publish) {
      const fs::path sim = fs::canonical("/proc/self/exe").parent_path() / "epmap-sim";
      PublishCase(sim, domain, publish_frames, 30);
      // As fast as rendering allows: frames are due every millisecond.
      PublishCase(sim, domain + 1, std::max(30, publish_frames / 2), 1000);
    }
    if (!skip_realism) RealismCase(realism_frames, shared);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "epmap-bench sim: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

EPMAP_BENCH_COMMAND(sim, "sim", "synthetic worlds: render cost, publish rate, SGBM realism", Run);
