// Expected perception from the command line (paper 000):
//   epmapctl expectation --out DIR      the newest frame's L-, E, C, A and unexpected mask as PNG
//   epmapctl unexpected --out mask.png  the newest unexpected mask (255 = moved on its own)
//   epmapctl watch-unexpected           one JSON line per frame where something moved

#include <google/protobuf/util/json_util.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <thread>

#include "clients/epmapctl/client.h"
#include "common/imaging/colormap.h"
#include "epmap/v1/map_service.grpc.pb.h"
#include "services/mapping/api/proto_conversions.h"

namespace {

using epmap::ctl::ClientOptions;
using Clock = std::chrono::steady_clock;

// E, C and A share one colour scale (grey levels) so that A's attenuation is visible.
constexpr float kErrorScaleMax = 40.0F;

std::string Json(const google::protobuf::Message& m) {
  google::protobuf::util::JsonPrintOptions print;
  print.preserve_proto_field_names = true;
  print.always_print_primitive_fields = true;
  std::string text;
  (void)google::protobuf::util::MessageToJsonString(m, &text, print);
  return text;
}

// The newest expectation; with want_predicted, polls until a predicted frame (one with L-, E,
// C, A) arrives or wait_ms passes.
grpc::Status FetchExpectation(const ClientOptions& options, bool want_predicted, uint32_t wait_ms,
                              epmap::v1::Expectation* out) {
  auto stub = epmap::v1::MapService::NewStub(options.Channel());
  const auto deadline = Clock::now() + std::chrono::milliseconds(wait_ms);
  while (true) {
    const auto context = options.Context();
    const grpc::Status rpc = stub->GetExpectation(context.get(), {}, out);
    const bool usable = rpc.ok() && (!want_predicted || out->error().width() > 0);
    if (usable || Clock::now() >= deadline) {
      if (rpc.ok() && !usable) {
        return {grpc::StatusCode::UNAVAILABLE,
                "the newest frame (" + out->frame_mode() +
                    ") was computed whole and has no prediction; try a larger --wait-ms"};
      }
      return rpc;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

struct ExpectationArgs {
  std::string out_dir;
  uint32_t wait_ms = 5000;
};

int RunExpectation(const ClientOptions& options, const ExpectationArgs& args) {
  epmap::v1::Expectation e;
  if (const auto rpc = FetchExpectation(options, true, args.wait_ms, &e); !rpc.ok()) {
    return options.Fail(rpc);
  }
  namespace fs = std::filesystem;
  using epmap::mapping::FromProto;
  try {
    fs::create_directories(args.out_dir);
    const fs::path dir(args.out_dir);
    epmap::ctl::WriteImageFile((dir / "predicted.png").string(), FromProto(e.predicted()));
    epmap::ctl::WriteImageFile((dir / "actual.png").string(), FromProto(e.actual()));
    epmap::ctl::WriteImageFile(
        (dir / "error.png").string(),
        epmap::imaging::ColorizeFloat(FromProto(e.error()), 0.0F, kErrorScaleMax));
    epmap::ctl::WriteImageFile(
        (dir / "accumulated.png").string(),
        epmap::imaging::ColorizeFloat(FromProto(e.accumulated()), 0.0F, kErrorScaleMax));
    epmap::ctl::WriteImageFile(
        (dir / "attenuated.png").string(),
        epmap::imaging::ColorizeFloat(FromProto(e.attenuated()), 0.0F, kErrorScaleMax));
    epmap::ctl::WriteImageFile((dir / "unexpected.png").string(), FromProto(e.unexpected_mask()));
    epmap::ctl::WriteImageFile((dir / "recomputed.png").string(), FromProto(e.recompute_mask()));
  } catch (const std::exception& ex) {
    std::cerr << "epmapctl: " << ex.what() << "\n";
    return 1;
  }
  std::printf(
      "wrote %s/{predicted,actual,error,accumulated,attenuated,unexpected,recomputed}.png "
      "for frame %llu (stamp %lld ns, %s): mean E %.2f, mean A %.2f (A/E %.2f), "
      "holes %.1f%%, recomputed %.1f%%, comparison grid step %u\n",
      args.out_dir.c_str(), static_cast<unsigned long long>(e.frame_index()),
      static_cast<long long>(e.stamp_ns()), e.frame_mode().c_str(), e.mean_error(),
      e.mean_attenuated(), e.mean_error() > 0 ? e.mean_attenuated() / e.mean_error() : 0.0,
      100.0 * e.hole_share(), 100.0 * e.recomputed_share(), e.grid_step());
  return 0;
}

struct UnexpectedArgs {
  std::string out;
  uint32_t min_area_px = 0;
  bool json = false;
};

int RunUnexpected(const ClientOptions& options, const UnexpectedArgs& args) {
  auto stub = epmap::v1::MapService::NewStub(options.Channel());
  epmap::v1::GetUnexpectedRegionsRequest request;
  request.set_min_area_px(args.min_area_px);
  epmap::v1::UnexpectedRegions regions;
  {
    const auto context = options.Context();
    if (const auto rpc = stub->GetUnexpectedRegions(context.get(), request, &regions); !rpc.ok()) {
      return options.Fail(rpc);
    }
  }
  if (!args.out.empty()) {
    epmap::v1::Expectation e;
    if (const auto rpc = FetchExpectation(options, false, 0, &e); !rpc.ok()) {
      return options.Fail(rpc);
    }
    try {
      epmap::ctl::WriteImageFile(args.out, epmap::mapping::FromProto(e.unexpected_mask()));
    } catch (const std::exception& ex) {
      std::cerr << "epmapctl: " << ex.what() << "\n";
      return 1;
    }
    if (!args.json)
      std::printf("wrote %s (frame %llu)\n", args.out.c_str(),
                  static_cast<unsigned long long>(e.frame_index()));
  }
  if (args.json) {
    std::printf("%s\n", Json(regions).c_str());
    return 0;
  }
  std::printf("frame %llu (stamp %lld ns): %.2f%% of the image moved on its own, %d region(s)\n",
              static_cast<unsigned long long>(regions.frame_index()),
              static_cast<long long>(regions.stamp_ns()), 100.0 * regions.flagged_share(),
              regions.regions_size());
  for (const auto& r : regions.regions()) {
    std::printf("  #%u box %dx%d+%d+%d, %u px, disparity %.1f px, base (%.3f, %.3f, %.3f) m%s",
                r.id(), r.width(), r.height(), r.x(), r.y(), r.area_px(), r.mean_disparity(),
                r.centroid_base().x(), r.centroid_base().y(), r.centroid_base().z(),
                r.base_corrected() ? " (eye-hand corrected)" : "");
    if (r.has_centroid_odom()) {
      std::printf(", odom (%.3f, %.3f, %.3f) m", r.centroid_odom().x(), r.centroid_odom().y(),
                  r.centroid_odom().z());
    }
    std::printf("\n");
  }
  return 0;
}

struct WatchArgs {
  uint32_t min_area_px = 0;
  bool include_empty = false;
  uint32_t count = 0;    // 0 = until stopped
  double seconds = 0.0;  // 0 = until stopped
};

int RunWatch(const ClientOptions& options, const WatchArgs& args) {
  auto stub = epmap::v1::MapService::NewStub(options.Channel());
  epmap::v1::WatchUnexpectedRequest request;
  request.set_min_area_px(args.min_area_px);
  request.set_include_empty(args.include_empty);
  // A stream has no overall deadline unless --seconds asks for one; --timeout is for calls.
  grpc::ClientContext context;
  if (args.seconds > 0) {
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::milliseconds(static_cast<int64_t>(args.seconds * 1000.0)));
  }
  auto reader = stub->WatchUnexpected(&context, request);
  epmap::v1::UnexpectedEvent event;
  uint32_t received = 0;
  while (reader->Read(&event)) {
    std::printf("%s\n", Json(event).c_str());
    std::fflush(stdout);
    if (args.count > 0 && ++received >= args.count) {
      context.TryCancel();
      break;
    }
  }
  const grpc::Status status = reader->Finish();
  const bool ended_as_asked =
      (args.count > 0 && received >= args.count) ||
      (args.seconds > 0 && status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED);
  if (status.ok() || ended_as_asked) return 0;
  return options.Fail(status);
}

void Setup(CLI::App& app, ClientOptions& options) {
  {
    auto* cmd = app.add_subcommand(
        "expectation", "write the newest frame's predicted image, E, C, A and masks as PNG");
    auto args = std::make_shared<ExpectationArgs>();
    cmd->add_option("--out", args->out_dir, "directory to write the PNGs into")->required();
    cmd->add_option("--wait-ms", args->wait_ms, "wait this long for a predicted frame");
    cmd->callback([&options, args] { options.exit_code = RunExpectation(options, *args); });
  }
  {
    auto* cmd = app.add_subcommand(
        "unexpected", "the regions of the newest frame that moved on their own (and the mask)");
    auto args = std::make_shared<UnexpectedArgs>();
    cmd->add_option("--out", args->out, "write the mask (255 = unexpected) to this PNG");
    cmd->add_option("--min-area", args->min_area_px, "ignore regions smaller than this (px)");
    cmd->add_flag("--json", args->json, "print the regions as JSON");
    cmd->callback([&options, args] { options.exit_code = RunUnexpected(options, *args); });
  }
  {
    auto* cmd = app.add_subcommand("watch-unexpected",
                                   "print one JSON line per frame where something moved");
    auto args = std::make_shared<WatchArgs>();
    cmd->add_option("--min-area", args->min_area_px, "ignore regions smaller than this (px)");
    cmd->add_flag("--include-empty", args->include_empty, "also print frames with no region");
    cmd->add_option("--count", args->count, "stop after this many events");
    cmd->add_option("--seconds", args->seconds, "stop after this long");
    cmd->callback([&options, args] { options.exit_code = RunWatch(options, *args); });
  }
}

}  // namespace

EPMAP_CTL_COMMAND(unexpected, Setup);
