// epmap-bench ingest --dataset DIR [--seconds 60] [--rate 30]: a stereo stream over real DDS
// into a real epmapd process for a while, then what arrived, what was lost where, how long
// frames took from arrival to snapshot, and epmapd's peak memory.
//
// Baseline in the same run: a plain DDS reader in this process on the same image topic sees
// the same stream, so transport alone (its count and stamp-to-arrival latency) stands beside
// the service's figures.
//
// --ros-listener on: a ROS 2 node's readers on rt/epmap/disparity and rt/epmap/unexpected_mask
// in this process during the run (what they received, stamp-to-arrival latency). both: the
// stream twice, without then with them, and what listening costs the service (its baseline is
// the run without).

#include <epmap/v1/map_service.grpc.pb.h>
#include <epmap_dds/DisparityImagePubSubTypes.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <grpcpp/grpcpp.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <optional>
#include <thread>

#include "bench/epmap_bench/command_registry.h"
#include "bench/epmap_bench/summary.h"
#include "clients/replay/dataset_publisher.h"
#include "common/dataset/dataset.h"
#include "common/dds/endpoints.h"
#include "common/dds/ros_conversions.h"
#include "common/process/child_process.h"
#include "common/process/process_memory.h"

namespace {

namespace fs = std::filesystem;
using namespace epmap::bench;

int64_t WallNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// From a message's stamp (the replay stamps with the wall clock it sends at) to now.
template <class Msg>
double MsSinceStamp(const Msg& msg) {
  return (WallNs() - epmap::dds::ToNanoseconds(msg.header().stamp())) / 1e6;
}

uint64_t Count(const google::protobuf::RepeatedPtrField<epmap::v1::Counter>& counters,
               const std::string& reason) {
  for (const auto& c : counters) {
    if (c.reason() == reason) return c.count();
  }
  return 0;
}

int Run(int argc, char** argv) {
  CLI::App app("stereo over DDS into epmapd: loss, latency, memory", argv[0]);
  std::string dataset_path, urdf, config;
  double seconds = 60.0, rate = 30.0;
  size_t preload = 90;
  int num_disparities = 0;
  app.add_option("--dataset", dataset_path, "dataset to stream (looped)")->required();
  app.add_option("--seconds", seconds, "how long to stream")->capture_default_str();
  app.add_option("--rate", rate, "frames per second")->capture_default_str();
  app.add_option("--preload", preload, "frames decoded into memory first")->capture_default_str();
  app.add_option("--urdf", urdf, "URDF for epmapd (default: the dataset's kinematics.urdf)");
  app.add_option("--config", config, "epmapd config file");
  app.add_option("--num-disparities", num_disparities, "epmapd --num-disparities");
  std::string ros_listener = "off";
  app.add_option("--ros-listener", ros_listener,
                 "read epmapd's ROS output (disparity, unexpected mask) during the run: off, on, "
                 "or both (two runs, without then with)")
      ->check(CLI::IsMember({"off", "on", "both"}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    const auto dataset = epmap::dataset::Load(dataset_path);
    if (urdf.empty() && dataset.urdf) urdf = dataset.urdf->string();
    struct Figures {
      uint64_t processed = 0, dropped = 0;
      double latency_p50 = 0;
    };
    const auto run_once = [&](bool listen) -> Figures {
      const uint32_t domain = static_cast<uint32_t>(::getpid() % 100 + 120);
      const int port = epmap::process::FreeTcpPort();
      const std::string address = "127.0.0.1:" + std::to_string(port);
      const fs::path bin_dir = fs::read_symlink("/proc/self/exe").parent_path();
      const fs::path log_dir =
          fs::temp_directory_path() / ("epmap-bench-ingest-" + std::to_string(::getpid()));
      fs::create_directories(log_dir);

      std::vector<std::string> args = {"--listen",    address, "--domain", std::to_string(domain),
                                       "--log-level", "warn"};
      if (!urdf.empty()) args.insert(args.end(), {"--urdf", urdf});
      if (!config.empty()) args.insert(args.end(), {"--config", config});
      if (num_disparities > 0)
        args.insert(args.end(), {"--num-disparities", std::to_string(num_disparities)});
      epmap::process::ChildProcess epmapd(bin_dir / "epmapd", args, log_dir / "epmapd.log");

      grpc::ChannelArguments channel_args;
      channel_args.SetMaxReceiveMessageSize(256 << 20);
      auto stub = epmap::v1::MapService::NewStub(
          grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), channel_args));
      const auto status = [&](epmap::v1::ServiceStatus* out) {
        grpc::ClientContext context;
        context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
        return stub->GetStatus(&context, {}, out).ok();
      };
      epmap::v1::ServiceStatus s;
      for (int i = 0; i < 200 && !status(&s); ++i) {
        if (!epmapd.running()) throw std::runtime_error("epmapd exited: " + epmapd.Output());
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }

      // Baseline: transport alone, measured by a plain reader in this process.
      epmap::dds::Participant participant(domain, "bench-baseline-reader");
      std::mutex mutex;
      std::vector<double> transport_ms;
      epmap::dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> baseline(
          participant, epmap::dds::TopicNames().left_image,
          [&](sensor_msgs::msg::Image&& msg) {
            const double ms = MsSinceStamp(msg);
            std::lock_guard lock(mutex);
            transport_ms.push_back(ms);
          },
          64u << 20);
      // A ROS 2 node listening to the service's output (--ros-listener).
      std::vector<double> ros_disparity_ms;
      std::atomic<uint64_t> ros_masks{0};
      using DisparityReader = epmap::dds::Reader<stereo_msgs::msg::DisparityImage,
                                                 stereo_msgs::msg::DisparityImagePubSubType>;
      using MaskReader =
          epmap::dds::Reader<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType>;
      std::optional<DisparityReader> ros_disparity;
      std::optional<MaskReader> ros_mask;
      if (listen) {
        ros_disparity.emplace(
            participant, epmap::dds::TopicNames().disparity,
            [&](stereo_msgs::msg::DisparityImage&& msg) {
              const double ms = MsSinceStamp(msg);
              std::lock_guard lock(mutex);
              ros_disparity_ms.push_back(ms);
            },
            64u << 20);
        ros_mask.emplace(
            participant, epmap::dds::TopicNames().unexpected_mask,
            [&](sensor_msgs::msg::Image&&) { ros_masks++; }, 64u << 20);
      }

      epmap::replay::ReplayOptions options;
      options.domain = domain;
      options.rate_hz = rate;
      options.loop_for_s = seconds;
      options.preload_frames = preload;
      std::fprintf(stderr, "epmap-bench ingest: streaming %s at %.0f Hz for %.0f s into epmapd\n",
                   dataset_path.c_str(), rate, seconds);
      const auto report = epmap::replay::Replay(dataset, options);

      // Let the pipeline drain its queue.
      for (int i = 0; i < 100; ++i) {
        if (status(&s) && s.queue_depth() == 0) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      status(&s);
      const double peak_mb =
          epmap::process::ReadProcessMemory(std::to_string(epmapd.pid())).peak_resident_mb;
      epmapd.Signal(SIGTERM);
      const auto code = epmapd.Wait(std::chrono::seconds(10));

      uint64_t dds_lost = 0;
      for (const auto& c : s.transport_lost_by_topic()) dds_lost += c.count();
      const uint64_t left_received = Count(s.messages_by_topic(), options.topics.left_image);
      std::lock_guard lock(mutex);
      std::printf(
          "{\"command\":\"ingest\",\"dataset\":\"%s\",\"width\":%d,\"height\":%d,\"rate_hz\":%.1f,"
          "\"seconds\":%.1f,\"frames_sent\":%zu,\"left_images_received\":%llu,"
          "\"frames_received\":%llu,\"frames_lost_in_transport\":%lld,\"dds_reported_lost\":%llu,"
          "\"frames_processed\":%llu,\"frames_rejected\":%llu,\"queue_dropped\":%llu,"
          "\"latency_ms_p50\":%.2f,\"latency_ms_p99\":%.2f,\"peak_rss_mb\":%.1f,"
          "\"recomputed_share_median\":%.4f,\"baseline_reader_received\":%zu,"
          "\"baseline_transport_ms_p50\":%s,\"baseline_transport_ms_p99\":%s,"
          "\"ros_listener\":%s,\"ros_disparity_received\":%zu,\"ros_disparity_ms_p50\":%s,"
          "\"ros_unexpected_masks_received\":%llu,\"epmapd_exit_code\":%d}\n",
          dataset_path.c_str(), dataset.cam0.width, dataset.cam0.height, rate, report.seconds,
          report.frames, static_cast<unsigned long long>(left_received),
          static_cast<unsigned long long>(s.frames_received()),
          static_cast<long long>(report.frames) - static_cast<long long>(s.frames_received()),
          static_cast<unsigned long long>(dds_lost),
          static_cast<unsigned long long>(s.frames_processed()),
          static_cast<unsigned long long>(s.frames_rejected()),
          static_cast<unsigned long long>(s.queue_dropped()), s.latency_ms_p50(),
          s.latency_ms_p99(), peak_mb, s.recomputed_share_median(), transport_ms.size(),
          FormatFixed(Percentile(transport_ms, 0.5), 2).c_str(),  // null without a sample
          FormatFixed(Percentile(transport_ms, 0.99), 2).c_str(), listen ? "true" : "false",
          ros_disparity_ms.size(), FormatFixed(Percentile(ros_disparity_ms, 0.5), 2).c_str(),
          static_cast<unsigned long long>(ros_masks.load()), code.value_or(-1));
      std::fflush(stdout);
      fs::remove_all(log_dir);
      return {s.frames_processed(), s.queue_dropped(), s.latency_ms_p50()};
    };
    if (ros_listener != "both") {
      run_once(ros_listener == "on");
      return 0;
    }
    const Figures without = run_once(false), with = run_once(true);
    std::printf(
        "{\"command\":\"ingest-ros-listener\",\"processed_without\":%llu,\"processed_with\":%llu,"
        "\"dropped_without\":%llu,\"dropped_with\":%llu,\"latency_ms_p50_without\":%.2f,"
        "\"latency_ms_p50_with\":%.2f,\"latency_ratio\":%s}\n",
        static_cast<unsigned long long>(without.processed),
        static_cast<unsigned long long>(with.processed),
        static_cast<unsigned long long>(without.dropped),
        static_cast<unsigned long long>(with.dropped), without.latency_p50, with.latency_p50,
        FormatFixed(without.latency_p50 > 0 ? with.latency_p50 / without.latency_p50 : NAN, 3)
            .c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "epmap-bench ingest: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

EPMAP_BENCH_COMMAND(ingest, "ingest",
                    "stereo over DDS into a real epmapd: loss, latency p50/p99, peak memory", Run);
