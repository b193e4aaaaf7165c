// epmapctl grid --out grid.pgm|grid.png [--layer N | --max-height M]
//               [--region MIN_X,MIN_Y,MAX_X,MAX_Y | --around-robot SIDE]: the fuzzy occupancy
// grid of a mobile base (issue 6), one height band, the bands a robot M tall can hit, or all
// combined; the whole map, or a window of it (a box in the world frame, or a square around the
// robot) as a local planner polls it.
// .pgm is written with a YAML beside it in the layout ROS map_server loads (image, resolution,
// origin, negate, occupied_thresh, free_thresh); .png is a picture for people.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <vector>

#include "clients/epmapctl/client.h"
#include "epmap/v1/map_service.grpc.pb.h"
#include "perception/occupancy/map_export.h"

namespace {

using epmap::ctl::ClientOptions;

struct Args {
  std::string out;
  std::optional<uint32_t> layer;
  std::optional<double> max_height_m;
  epmap::ctl::MapWindow window;
  epmap::ctl::MapsWait wait;
};

// What the grid holds, for the summary line: "layer 1 (0.70-1.30 m)", "all layers combined" or
// "layers 0-0 combined (0.10-0.70 m)".
std::string Describe(const epmap::occupancy::GridExport& e) {
  const auto& b = e.layer_bounds_m;
  const auto band = [&](uint32_t lo, uint32_t hi) {
    if (lo > hi || hi + 1 >= b.size()) return std::string();  // no bounds sent
    char text[64];
    std::snprintf(text, sizeof text, " (%.2f-%.2f m)", b[lo], b[hi + 1]);
    return std::string(text);
  };
  if (!e.combined) return "layer " + std::to_string(e.layer) + band(e.layer, e.layer);
  if (e.combined_layers == 0 || e.combined_layers >= e.layer_count) return "all layers combined";
  return "layers 0-" + std::to_string(e.combined_layers - 1) + " combined" +
         band(0, e.combined_layers - 1);
}

epmap::occupancy::GridExport FromProto(const epmap::v1::OccupancyGrid& g) {
  epmap::occupancy::GridExport e;
  e.resolution_m = g.resolution_m();
  e.origin_x = g.origin().x();
  e.origin_y = g.origin().y();
  e.width = g.width();
  e.height = g.height();
  e.layer_count = g.layer_count();
  e.layer_bounds_m.assign(g.layer_bounds_m().begin(), g.layer_bounds_m().end());
  e.combined = g.combined();
  e.layer = g.layer();
  e.combined_layers = g.combined_layers();
  e.occupancy.assign(g.occupancy().begin(), g.occupancy().end());
  e.confidence.assign(g.confidence().begin(), g.confidence().end());
  return e;
}

void WriteFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
  if (!out.flush()) throw std::runtime_error("cannot write " + path.string());
}

int Run(const ClientOptions& options, const Args& args) {
  const std::filesystem::path out(args.out);
  const std::string ext = out.extension().string();
  if (ext != ".pgm" && ext != ".png") {
    std::cerr << "epmapctl: --out must end in .pgm (map_server, with a .yaml beside it) or .png\n";
    return 2;
  }
  auto stub = epmap::v1::MapService::NewStub(options.Channel());
  epmap::v1::GetOccupancyGridRequest request;
  if (args.layer) request.set_layer(*args.layer);
  if (args.max_height_m) request.set_max_height_m(*args.max_height_m);
  args.window.Apply(&request);
  args.wait.Apply(&request);
  epmap::v1::OccupancyGrid grid;
  const auto context = options.Context(args.wait.wait_ms);
  const grpc::Status rpc = stub->GetOccupancyGrid(context.get(), request, &grid);
  if (!rpc.ok()) return options.Fail(rpc);
  const auto e = FromProto(grid);
  if (e.occupancy.size() != static_cast<size_t>(e.width) * e.height) {
    std::cerr << "epmapctl: the server sent " << e.occupancy.size() << " cells for a " << e.width
              << "x" << e.height << " grid\n";
    return 1;
  }
  std::filesystem::path yaml;
  try {
    if (ext == ".pgm") {
      WriteFile(out, epmap::occupancy::EncodePgm(e));
      yaml = std::filesystem::path(out).replace_extension(".yaml");
      WriteFile(yaml, epmap::occupancy::MapServerYaml(e, out.filename().string()));
    } else {
      epmap::ctl::WriteImageFile(out.string(), epmap::occupancy::RenderGrid(e));
    }
  } catch (const std::exception& ex) {
    std::cerr << "epmapctl: " << ex.what() << "\n";
    return 1;
  }
  std::printf(
      "wrote %s%s%s: %ux%u cells of %.3f m%s, origin (%.3f, %.3f), %s (stamp %lld ns)%s%s\n",
      out.string().c_str(), yaml.empty() ? "" : " and ", yaml.string().c_str(), e.width, e.height,
      e.resolution_m, grid.window() ? " (the window asked for)" : "", e.origin_x, e.origin_y,
      Describe(e).c_str(), static_cast<long long>(grid.stamp_ns()),
      grid.includes_open_stop() ? ", with the stop under way (provisional)" : "",
      grid.resumed_unconfirmed() ? epmap::ctl::kResumedNote : "");
  return 0;
}

void Setup(CLI::App& app, ClientOptions& options) {
  auto* cmd = app.add_subcommand("grid", "write the occupancy grid (mobile-base mode) to a file");
  auto args = std::make_shared<Args>();
  cmd->add_option("--out", args->out, "FILE.pgm (+ FILE.yaml, ROS map_server) or FILE.png")
      ->required();
  auto* layer =
      cmd->add_option("--layer", args->layer, "height band (0 = lowest); default: all combined");
  cmd->add_option("--max-height", args->max_height_m,
                  "the bands a robot this tall (m) can hit, combined (those starting below it)")
      ->excludes(layer);
  args->window.AddOptions(cmd, "the cells");
  args->wait.AddOptions(cmd);
  cmd->callback([&options, args] { options.exit_code = Run(options, *args); });
}

}  // namespace

EPMAP_CTL_COMMAND(grid, Setup);
