// epmapctl reset-maps [--json]: forgets the mobile base's maps and the saved ones (the robot is
// on another floor, or the maps went wrong); the next key frames start new maps.

#include <cstdio>

#include "clients/epmapctl/client.h"
#include "epmap/v1/map_service.grpc.pb.h"

namespace {

using epmap::ctl::ClientOptions;

int Run(const ClientOptions& options, bool json) {
  auto stub = epmap::v1::MapService::NewStub(options.Channel());
  epmap::v1::ResetMapsResponse response;
  const auto context = options.Context(0);
  const grpc::Status rpc = stub->ResetMaps(context.get(), {}, &response);
  if (!rpc.ok()) return options.Fail(rpc);
  if (json) {
    std::printf("{\"key_frames_dropped\":%llu,\"saved_maps_cleared\":%s}\n",
                static_cast<unsigned long long>(response.key_frames_dropped()),
                response.saved_maps_cleared() ? "true" : "false");
    return 0;
  }
  std::printf("maps reset: %llu key frames dropped at the next frame; %s\n",
              static_cast<unsigned long long>(response.key_frames_dropped()),
              response.saved_maps_cleared() ? "the saved maps are cleared"
                                            : "no durable maps (no state dir, maps.persist "
                                              "off, or the store unavailable: see status)");
  return 0;
}

void Setup(CLI::App& app, ClientOptions& options) {
  auto* cmd = app.add_subcommand(
      "reset-maps", "forget the maps and the saved ones; new maps start (mobile base)");
  auto json = std::make_shared<bool>(false);
  cmd->add_flag("--json", *json, "one JSON object instead of text");
  cmd->callback([&options, json] { options.exit_code = Run(options, *json); });
}

}  // namespace

EPMAP_CTL_COMMAND(reset_maps, Setup);
