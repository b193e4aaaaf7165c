// epmapctl disparity --out FILE.pfm|FILE.png [--wait-ms N]: the newest disparity map.
// .pfm keeps float32 pixels (non-finite = unknown) for tools; .png is colour-mapped for people.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "clients/epmapctl/client.h"
#include "common/imaging/colormap.h"
#include "common/imaging/pfm.h"
#include "epmap/v1/map_service.grpc.pb.h"
#include "services/mapping/api/proto_conversions.h"

namespace {

using epmap::ctl::ClientOptions;

struct Args {
  std::string out;
  uint32_t wait_ms = 0;
};

int Run(const ClientOptions& options, const Args& args) {
  const std::string ext = std::filesystem::path(args.out).extension().string();
  if (ext != ".pfm" && ext != ".png") {
    std::cerr << "epmapctl: --out must end in .pfm (float32) or .png (colour-mapped)\n";
    return 2;
  }
  auto stub = epmap::v1::MapService::NewStub(options.Channel());
  epmap::v1::GetDisparityRequest request;
  request.set_wait_ms(args.wait_ms);
  epmap::v1::DisparityMap map;
  const auto context = options.Context(args.wait_ms);  // the server may wait that long
  const grpc::Status rpc = stub->GetDisparity(context.get(), request, &map);
  if (!rpc.ok()) return options.Fail(rpc);
  const cv::Mat disparity = epmap::mapping::FromProto(map.disparity());
  try {
    if (ext == ".pfm") {
      epmap::imaging::WritePfm(args.out, disparity);
    } else {
      const float lo = static_cast<float>(map.min_disparity());
      const float hi = static_cast<float>(map.min_disparity() + map.num_disparities());
      epmap::ctl::WriteImageFile(args.out, epmap::imaging::ColorizeFloat(disparity, lo, hi));
    }
  } catch (const std::exception& e) {
    std::cerr << "epmapctl: " << e.what() << "\n";
    return 1;
  }
  std::printf(
      "wrote %s: %dx%d disparity of frame %llu (stamp %lld ns), %.1f%% known, "
      "fx %.1f px, baseline %.4f m\n",
      args.out.c_str(), disparity.cols, disparity.rows,
      static_cast<unsigned long long>(map.frame_index()), static_cast<long long>(map.stamp_ns()),
      100.0 * map.valid_share(), map.camera().fx(), map.camera().baseline_m());
  return 0;
}

void Setup(CLI::App& app, ClientOptions& options) {
  auto* cmd = app.add_subcommand("disparity", "write the newest disparity map to a file");
  auto args = std::make_shared<Args>();
  cmd->add_option("--out", args->out, "FILE.pfm (float32, NaN = unknown) or FILE.png (colour)")
      ->required();
  cmd->add_option("--wait-ms", args->wait_ms, "wait this long for a first frame (max 30000)");
  cmd->callback([&options, args] { options.exit_code = Run(options, *args); });
}

}  // namespace

EPMAP_CTL_COMMAND(disparity, Setup);
