// epmapctl pmap --out map.svg|map.json [--kept-only]
//              [--region MIN_X,MIN_Y,MAX_X,MAX_Y | --around-robot SIDE]: the perceptual map of a
// mobile base (issue 6), or only the segments paper 003's redundancy removal keeps (III-D, its
// Fig. 10), or only those in a window (a box of the world frame, or a square around the robot).
// .json in the layout `epmap-bench maps` writes (metres, world frame = the robot's start
// pose): {"stamp_ns","includes_open_stop","resumed_unconfirmed","segments_in_map","window",
// "segments":[{"id","x1","y1","x2","y2","view_id","observations","kept"}],"path":[[x,y]],
// "boundary":[[x,y]],"inner_boundary":[[x,y]],"views":[...]}; .svg a picture for people.

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>

#include "clients/epmapctl/client.h"
#include "epmap/v1/map_service.grpc.pb.h"

namespace {

using epmap::ctl::ClientOptions;

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4f", v);
  return buf;
}

std::string Points(const google::protobuf::RepeatedPtrField<epmap::v1::Point2D>& points) {
  std::string s = "[";
  for (int i = 0; i < points.size(); ++i) {
    s += (i ? ",[" : "[") + Num(points[i].x()) + "," + Num(points[i].y()) + "]";
  }
  return s + "]";
}

std::string Json(const epmap::v1::PerceptualMap& m) {
  std::ostringstream s;
  s << "{\"stamp_ns\":" << m.stamp_ns()
    << ",\"includes_open_stop\":" << (m.includes_open_stop() ? "true" : "false")
    << ",\"resumed_unconfirmed\":" << (m.resumed_unconfirmed() ? "true" : "false")
    << ",\"segments_in_map\":" << m.segments_in_map()
    << ",\"window\":" << (m.window() ? "true" : "false") << ",\"segments\":[";
  for (int i = 0; i < m.segments_size(); ++i) {
    const auto& g = m.segments(i);
    s << (i ? "," : "") << "{\"id\":" << g.id() << ",\"x1\":" << Num(g.x1())
      << ",\"y1\":" << Num(g.y1()) << ",\"x2\":" << Num(g.x2()) << ",\"y2\":" << Num(g.y2())
      << ",\"view_id\":" << g.view_id() << ",\"observations\":" << g.observations()
      << ",\"kept\":" << (g.kept() ? "true" : "false") << "}";
  }
  s << "],\"path\":" << Points(m.path()) << ",\"boundary\":" << Points(m.boundary())
    << ",\"inner_boundary\":" << Points(m.inner_boundary()) << ",\"views\":[";
  for (int i = 0; i < m.views_size(); ++i) {
    const auto& v = m.views(i);
    s << (i ? "," : "") << "{\"id\":" << v.id() << ",\"stamp_ns\":" << v.stamp_ns()
      << ",\"x\":" << Num(v.pose().x()) << ",\"y\":" << Num(v.pose().y())
      << ",\"theta\":" << Num(v.pose().theta()) << ",\"segments\":" << v.segments() << "}";
  }
  s << "]}\n";
  return s.str();
}

// Segments dark red (pale and thin where the redundancy removal drops them), path blue, outer
// boundary green, inner boundary orange; y up, 50 px/m.
std::string Svg(const epmap::v1::PerceptualMap& m) {
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  const auto grow = [&](double x, double y) {
    x0 = std::min(x0, x);
    y0 = std::min(y0, y);
    x1 = std::max(x1, x);
    y1 = std::max(y1, y);
  };
  for (const auto& g : m.segments()) {
    grow(g.x1(), g.y1());
    grow(g.x2(), g.y2());
  }
  for (const auto& p : m.path()) grow(p.x(), p.y());
  if (!(x1 >= x0)) x0 = y0 = -1, x1 = y1 = 1;
  const double scale = 50, margin = 1.0;
  const auto X = [&](double x) { return Num((x - x0 + margin) * scale); };
  const auto Y = [&](double y) { return Num((y1 - y + margin) * scale); };
  std::ostringstream s;
  s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << Num((x1 - x0 + 2 * margin) * scale)
    << "\" height=\"" << Num((y1 - y0 + 2 * margin) * scale) << "\">\n"
    << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  const auto polyline = [&](const auto& points, const char* colour) {
    if (points.empty()) return;
    s << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"1.5\" points=\"";
    for (const auto& p : points) s << X(p.x()) << "," << Y(p.y()) << " ";
    s << "\"/>\n";
  };
  polyline(m.boundary(), "green");
  polyline(m.inner_boundary(), "orange");
  polyline(m.path(), "blue");
  // The dropped ones first: the kept ones are drawn over them.
  for (const bool kept : {false, true}) {
    for (const auto& g : m.segments()) {
      if (g.kept() != kept) continue;
      s << "<line x1=\"" << X(g.x1()) << "\" y1=\"" << Y(g.y1()) << "\" x2=\"" << X(g.x2())
        << "\" y2=\"" << Y(g.y2()) << "\" stroke=\"" << (kept ? "darkred" : "#e0a8a8")
        << "\" stroke-width=\"" << (kept ? 2 : 1) << "\"><title>id " << g.id()
        << (kept ? "" : " (redundant)") << "</title></line>\n";
    }
  }
  s << "</svg>\n";
  return s.str();
}

struct Args {
  std::string out;
  bool kept_only = false;
  epmap::ctl::MapWindow window;
  epmap::ctl::MapsWait wait;
};

int Run(const ClientOptions& options, const Args& args) {
  const std::string& out_path = args.out;
  const std::string ext = std::filesystem::path(out_path).extension().string();
  if (ext != ".svg" && ext != ".json") {
    std::cerr << "epmapctl: --out must end in .svg (picture) or .json (segments, path, boundary)\n";
    return 2;
  }
  auto stub = epmap::v1::MapService::NewStub(options.Channel());
  epmap::v1::PerceptualMap map;
  epmap::v1::GetPerceptualMapRequest request;
  args.wait.Apply(&request);
  request.set_kept_only(args.kept_only);
  args.window.Apply(&request);
  const auto context = options.Context(args.wait.wait_ms);
  const grpc::Status rpc = stub->GetPerceptualMap(context.get(), request, &map);
  if (!rpc.ok()) return options.Fail(rpc);
  std::ofstream out(out_path, std::ios::binary);
  out << (ext == ".json" ? Json(map) : Svg(map));
  if (!out.flush()) {
    std::cerr << "epmapctl: cannot write " << out_path << "\n";
    return 1;
  }
  const auto kept = std::count_if(map.segments().begin(), map.segments().end(),
                                  [](const epmap::v1::MapSegment& g) { return g.kept(); });
  std::printf(
      "wrote %s: %d segments of %u%s (%ld kept by the redundancy removal), %d views, path "
      "of %d points (stamp %lld ns)%s%s\n",
      out_path.c_str(), map.segments_size(), map.segments_in_map(),
      map.window() ? " (those in the window)" : "", static_cast<long>(kept), map.views_size(),
      map.path_size(), static_cast<long long>(map.stamp_ns()),
      map.includes_open_stop() ? ", with the stop under way (provisional)" : "",
      map.resumed_unconfirmed() ? epmap::ctl::kResumedNote : "");
  return 0;
}

void Setup(CLI::App& app, ClientOptions& options) {
  auto* cmd = app.add_subcommand("pmap", "write the perceptual map (mobile-base mode) to a file");
  auto args = std::make_shared<Args>();
  cmd->add_option("--out", args->out, "FILE.svg (picture) or FILE.json (metres, world frame)")
      ->required();
  cmd->add_flag("--kept-only", args->kept_only,
                "only the segments the redundancy removal keeps (paper 003 III-D, its Fig. 10)");
  args->window.AddOptions(cmd, "the segments with some part");
  args->wait.AddOptions(cmd);
  cmd->callback([&options, args] { options.exit_code = Run(options, *args); });
}

}  // namespace

EPMAP_CTL_COMMAND(pmap, Setup);
