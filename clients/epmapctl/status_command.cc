// epmapctl status [--json]: counters, timings and health of the service.

#include <google/protobuf/util/json_util.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include "clients/epmapctl/client.h"
#include "epmap/v1/map_service.grpc.pb.h"

namespace {

using epmap::ctl::ClientOptions;

// A titled list of counters, one "reason count" line each; nothing when the list is empty
// (unless always).
void PrintCounters(const char* title,
                   const google::protobuf::RepeatedPtrField<epmap::v1::Counter>& counters,
                   bool always = false) {
  if (counters.empty() && !always) return;
  std::printf("%s:\n", title);
  for (const auto& c : counters) {
    std::printf("  %-44s %llu\n", c.reason().c_str(), static_cast<unsigned long long>(c.count()));
  }
}

void PrintHuman(const epmap::v1::ServiceStatus& s) {
  std::printf("epmapd %s, up %.1f s, mode %s\n", s.version().c_str(), s.uptime_s(),
              s.mode().c_str());
  std::printf(
      "frames: %llu received, %llu processed, %llu rejected, %llu dropped in queue "
      "(depth %u/%u)\n",
      static_cast<unsigned long long>(s.frames_received()),
      static_cast<unsigned long long>(s.frames_processed()),
      static_cast<unsigned long long>(s.frames_rejected()),
      static_cast<unsigned long long>(s.queue_dropped()), s.queue_depth(), s.queue_capacity());
  if (s.last_stamp_ns()) {
    std::printf("last frame stamp: %lld ns\n", static_cast<long long>(s.last_stamp_ns()));
  }
  std::printf("ingest-to-snapshot latency: p50 %.1f ms, p99 %.1f ms\n", s.latency_ms_p50(),
              s.latency_ms_p99());
  std::printf("recomputed share: last %.3f, median %.3f, mean %.3f; full refreshes %llu\n",
              s.recomputed_share_last(), s.recomputed_share_median(), s.recomputed_share_mean(),
              static_cast<unsigned long long>(s.full_refreshes()));
  if (s.unexpected_watchers())
    std::printf("watch-unexpected streams: %u\n", s.unexpected_watchers());
  if (s.resident_mb() > 0) {
    std::printf("memory: resident %.1f MB, peak %.1f MB\n", s.resident_mb(), s.peak_resident_mb());
  }
  if (s.has_robot()) {
    const auto& r = s.robot();
    std::string joints;
    for (const auto& j : r.joints()) joints += (joints.empty() ? "" : ", ") + j;
    std::printf("robot: %s, root %s, cameras %s / %s, joints [%s], camera pose from %s\n",
                r.urdf().c_str(), r.root_link().c_str(), r.left_camera_link().c_str(),
                r.right_camera_link().empty() ? "(none)" : r.right_camera_link().c_str(),
                joints.c_str(), r.pose_source().c_str());
  } else {
    std::printf("robot: no URDF (robot.urdf, --urdf or --urdf-topic)\n");
  }
  if (s.has_saved_maps()) {
    const auto& m = s.saved_maps();
    if (m.saved()) {
      const double age_s = (std::chrono::duration_cast<std::chrono::nanoseconds>(
                                std::chrono::system_clock::now().time_since_epoch())
                                .count() -
                            m.saved_unix_ns()) *
                           1e-9;
      std::printf("saved maps: %s, %llu key frames, %.1f MB, saved %.0f s ago\n", m.path().c_str(),
                  static_cast<unsigned long long>(m.key_frames()), m.bytes() / 1e6, age_s);
    } else {
      std::printf("saved maps: %s, none saved yet (or reset)\n", m.path().c_str());
    }
  }
  PrintCounters("rejected", s.rejected_by_reason());
  PrintCounters("key frames the maps refused (their frames were processed)",
                s.key_frames_refused_by_reason());
  PrintCounters("queue drops", s.queue_drops_by_reason());
  PrintCounters("lost in transport", s.transport_lost_by_topic());
  PrintCounters("messages by topic", s.messages_by_topic(), /*always=*/true);
  if (s.stages_size()) {
    std::printf("stages (ms):            last   median     mean      p99  samples\n");
    for (const auto& t : s.stages()) {
      std::printf("  %-18s %8.2f %8.2f %8.2f %8.2f %8llu\n", t.stage().c_str(), t.last_ms(),
                  t.median_ms(), t.mean_ms(), t.p99_ms(),
                  static_cast<unsigned long long>(t.samples()));
    }
  }
  PrintCounters("events", s.events());
  if (!s.active_eye_hand_model().empty() || !s.active_stereo_model().empty()) {
    std::printf("active models: eye-hand %s, stereo %s\n", s.active_eye_hand_model().c_str(),
                s.active_stereo_model().c_str());
  }
}

void Setup(CLI::App& app, ClientOptions& options) {
  auto* cmd = app.add_subcommand("status", "counters, timings and health of epmapd");
  auto json = std::make_shared<bool>(false);
  cmd->add_flag("--json", *json, "print the status as JSON");
  cmd->callback([&options, json] {
    auto stub = epmap::v1::MapService::NewStub(options.Channel());
    epmap::v1::ServiceStatus status;
    const auto context = options.Context();
    const grpc::Status rpc = stub->GetStatus(context.get(), {}, &status);
    if (!rpc.ok()) {
      options.exit_code = options.Fail(rpc);
      return;
    }
    if (*json) {
      std::string text;
      google::protobuf::util::JsonPrintOptions print;
      print.always_print_primitive_fields = true;
      print.preserve_proto_field_names = true;
      (void)google::protobuf::util::MessageToJsonString(status, &text, print);
      std::cout << text << "\n";
    } else {
      PrintHuman(status);
    }
  });
}

}  // namespace

EPMAP_CTL_COMMAND(status, Setup);
