// epmap-bench boundary [--lengths 60,250,1000,4000] [--revisits 4,16] [--repeat N]: how the
// perceptual map's redundancy removal and boundary (paper 003, Sec. III-D) scale with the length of
// the run. A service that maps for hours recomputes it each time a view joins the map (and at every
// key frame of a stop, for the provisional map): comparing every object with every path point
// grows with the map times the path. The cell-grid index (BoundaryParams::index_cell_m) is
// timed beside that baseline (index_cell_m = 0) on the same synthetic maps, and both boundaries
// are checked to be identical.
//
// The synthetic floor: a path of the given length in 50 m rows 4 m apart (a serpentine through
// a large building), a view every metre, and at each view one 0.8 m wall segment 1.5 m to
// either side with a few centimetres of scatter: about as many objects per metre as the
// building scenario's perceptual map has. --revisits drives a 250 m floor again and again.
//
// --pmap FILE times the same on a perceptual map a run built (pmap.json of `epmap-bench maps`
// or `epmapctl pmap --out map.json`: its segments and path), e.g. the building floor driven
// four times (`epmap-sim record --scenario building --route rooms --passes 4`), where the
// synthetic floor's regular walls say little about how real ones crowd the index's cells.

#include <CLI/CLI.hpp>
#include <chrono>
#include <fstream>
#include <iostream>
#include <iterator>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "bench/epmap_bench/command_registry.h"
#include "bench/epmap_bench/summary.h"
#include "perception/perceptual_map/boundary.h"

namespace {

namespace pm = epmap::perceptual_map;

struct Floor {
  std::vector<pm::MapSegment> segments;
  std::vector<Eigen::Vector2d> path;
};

// A serpentine floor_m long, driven `passes` times (turning back at each end), each pass
// seeing the walls afresh: the perceptual map is never corrected (paper 003, Sec. II), so a
// floor driven again gets its walls again, and the map grows denser rather than wider.
Floor Serpentine(int floor_m, int passes) {
  Floor f;
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> scatter(-0.05, 0.05);
  uint32_t id = 1;
  for (int pass = 0; pass < passes; ++pass) {
    for (int step = pass == 0 ? 0 : 1; step <= floor_m; ++step) {
      const int i = pass % 2 ? floor_m - step : step;
      const int row = i / 50, along = i % 50;
      const Eigen::Vector2d p(row % 2 ? 50 - along : along, 4.0 * row);
      f.path.push_back(p);
      for (const double side : {-1.5, 1.5}) {
        pm::MapSegment s;
        s.id = id++;
        s.a = p + Eigen::Vector2d(scatter(rng), side + scatter(rng));
        s.b = p + Eigen::Vector2d(0.8 + scatter(rng), side + scatter(rng));
        f.segments.push_back(s);
      }
    }
  }
  return f;
}

// The segments and path of a pmap.json (see the top of this file). Only what this bench needs
// is read: every {"id":..,"x1":..,"y1":..,"x2":..,"y2":..} object and the "path" array of
// [x,y] pairs. Throws std::runtime_error naming the file when either is missing.
Floor ReadPmapJson(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot read " + file);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string num = R"((-?[0-9.]+(?:[eE][-+]?[0-9]+)?))";
  const std::regex segment("\\{\"id\":([0-9]+),\"x1\":" + num + ",\"y1\":" + num +
                           ",\"x2\":" + num + ",\"y2\":" + num);
  Floor f;
  for (std::sregex_iterator it(text.begin(), text.end(), segment), end; it != end; ++it) {
    pm::MapSegment s;
    s.id = static_cast<uint32_t>(std::stoul((*it)[1]));
    s.a = {std::stod((*it)[2]), std::stod((*it)[3])};
    s.b = {std::stod((*it)[4]), std::stod((*it)[5])};
    f.segments.push_back(s);
  }
  const size_t path_at = text.find("\"path\":[");
  if (f.segments.empty() || path_at == std::string::npos) {
    throw std::runtime_error(file + " holds no perceptual map (segments and path of pmap.json)");
  }
  const size_t path_end = text.find("]]", path_at);
  const std::string path = text.substr(
      path_at, path_end == std::string::npos ? std::string::npos : path_end + 2 - path_at);
  const std::regex point("\\[" + num + "," + num + "\\]");
  for (std::sregex_iterator it(path.begin(), path.end(), point), end; it != end; ++it) {
    f.path.emplace_back(std::stod((*it)[1]), std::stod((*it)[2]));
  }
  return f;
}

bool Same(const pm::Boundary& a, const pm::Boundary& b) {
  return a.removed_on_path == b.removed_on_path && a.inner_ids == b.inner_ids &&
         a.outer_ids == b.outer_ids && a.inner == b.inner && a.outer == b.outer &&
         a.inner_is_left == b.inner_is_left;
}

int Run(int argc, char** argv) {
  CLI::App app("Paper 003 III-D boundary: cell-grid index vs comparing everything", argv[0]);
  std::vector<int> lengths = {60, 250, 1000, 4000};
  std::vector<int> revisits = {4, 16};
  int repeat = 5;
  app.add_option("--lengths", lengths, "path lengths, metres (one pass each)")->delimiter(',');
  app.add_option("--revisits", revisits,
                 "passes over one 250 m floor, each adding its walls again (the map grows "
                 "denser)")
      ->delimiter(',');
  app.add_option("--repeat", repeat, "timed runs of each method per length (median reported)")
      ->check(CLI::Range(1, 1000));
  std::vector<std::string> pmaps;
  app.add_option("--pmap", pmaps,
                 "also time these perceptual maps a run built (pmap.json: segments and path)")
      ->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);
  for (const int l : lengths) {
    if (l < 2 || l > 100000) {
      std::cerr << "epmap-bench boundary: --lengths must be within 2..100000 m, got " << l << "\n";
      return 2;
    }
  }
  for (const int p : revisits) {
    if (p < 1 || p > 400) {
      std::cerr << "epmap-bench boundary: --revisits must be within 1..400, got " << p << "\n";
      return 2;
    }
  }
  constexpr int kRevisitedFloorM = 250;
  struct Case {
    int floor_m = 0, passes = 0;
    std::string pmap;  // a run's map instead of a synthetic floor
  };
  std::vector<Case> cases;
  for (const int l : lengths) cases.push_back({l, 1, {}});
  for (const int p : revisits) cases.push_back({kRevisitedFloorM, p, {}});
  for (const auto& file : pmaps) cases.push_back({0, 0, file});
  using epmap::bench::FormatFixed;
  std::ostringstream j;
  j << "{\"what\":\"paper 003 III-D redundancy removal and boundary, per call\""
    << ",\"baseline\":\"every object against every path point and line (index_cell_m 0)\""
    << ",\"index_cell_m\":" << FormatFixed(pm::BoundaryParams{}.index_cell_m, 2) << ",\"runs\":[";
  bool all_same = true;
  for (size_t k = 0; k < cases.size(); ++k) {
    Floor floor;
    try {
      floor = cases[k].pmap.empty() ? Serpentine(cases[k].floor_m, cases[k].passes)
                                    : ReadPmapJson(cases[k].pmap);
    } catch (const std::exception& e) {
      std::cerr << "epmap-bench boundary: " << e.what() << "\n";
      return 2;
    }
    pm::BoundaryParams indexed, everything;
    everything.index_cell_m = 0;
    std::vector<double> indexed_ms, baseline_ms;
    pm::Boundary a, b;
    for (int r = 0; r < repeat; ++r) {  // interleaved: the machine's load falls on both alike
      auto t0 = std::chrono::steady_clock::now();
      a = pm::ComputeBoundary(floor.segments, floor.path, indexed);
      indexed_ms.push_back(epmap::bench::MsSince(t0));
      t0 = std::chrono::steady_clock::now();
      b = pm::ComputeBoundary(floor.segments, floor.path, everything);
      baseline_ms.push_back(epmap::bench::MsSince(t0));
    }
    const bool same = Same(a, b);
    all_same = all_same && same;
    const double im = epmap::bench::Median(indexed_ms), bm = epmap::bench::Median(baseline_ms);
    j << (k ? "," : "") << "{";
    if (cases[k].pmap.empty()) {
      j << "\"path_m\":" << cases[k].floor_m * cases[k].passes << ",\"passes\":" << cases[k].passes;
    } else {
      j << "\"pmap\":" << epmap::bench::JsonQuote(cases[k].pmap)
        << ",\"path_points\":" << floor.path.size();
    }
    j << ",\"objects\":" << floor.segments.size()
      << ",\"kept\":" << a.inner_ids.size() + a.outer_ids.size()
      << ",\"indexed_ms_median\":" << FormatFixed(im, 3)
      << ",\"baseline_ms_median\":" << FormatFixed(bm, 3)
      << ",\"ratio_to_baseline\":" << FormatFixed(im / bm, 4)
      << ",\"same_boundary\":" << (same ? "true" : "false") << "}";
  }
  j << "],\"all_same\":" << (all_same ? "true" : "false") << "}";
  std::cout << j.str() << "\n";
  if (!all_same) {
    std::cerr << "epmap-bench boundary: the indexed boundary differs from the baseline's\n";
    return 1;
  }
  return 0;
}

}  // namespace

EPMAP_BENCH_COMMAND(boundary, "boundary", "perceptual-map boundary (III-D) vs path length", Run);
