#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "tests/support/planar_world.h"
#include "tests/support/test_env.h"

namespace epmap {
namespace {

std::string Slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs `epmap-bench ARGS`, which must fail, and returns what it wrote to stderr (the reason).
std::string RefusalOf(const std::string& args, const std::filesystem::path& dir) {
  const auto err = dir / "refusal.txt";
  const std::string cmd =
      (testing::BinDir() / "epmap-bench").string() + " " + args + " > /dev/null 2> " + err.string();
  EXPECT_NE(std::system(cmd.c_str()), 0) << cmd;
  return Slurp(err);
}

// `epmap-bench maps` end to end on a short synthetic run written in the dataset layout:
// every output is there, in its documented shape, and the figures are computed.
TEST(MapsBench, WritesTheMapsAndTheFigures) {
  const auto dir = testing::FreshTempDir("maps-bench");
  testing::RunParams rp;
  rp.pan_stops = {0.0, 0.6, 0.0, -0.6, 0.0};
  rp.pan_rate = 3.0;
  const auto run = testing::SimulateRun({{1.0, 1.0}, {2.5, 1.0}, {2.0, 3.0}}, 0.0, rp);
  testing::WriteRunDataset(testing::PlanarWorld(testing::RoomWalls()), run, dir / "data");

  const auto bench = testing::BinDir() / "epmap-bench";
  const std::string cmd = bench.string() + " maps --dataset " + (dir / "data").string() +
                          " --out " + (dir / "out").string() + " --json > " +
                          (dir / "figures.txt").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

  const std::string figures = Slurp(dir / "figures.txt");
  for (const char* key : {"\"odometry_final_error_deg\":",
                          "\"corrected_final_error_deg\":",
                          "\"wall_coverage_0p5m\":",
                          "\"visible_wall_share\":",
                          "\"stray_share_1m\":",
                          "\"iou\":",
                          "\"iou_upper_bound\":",
                          "\"wall_coverage_seen_bound\":",
                          "\"seen_wall_coverage_0p5m\":",
                          "\"no_heading_correction\":",
                          "\"per_key_frame_ms_median\":",
                          "\"baseline_sgbm_ms_median\":",
                          "\"correlation\":{\"enabled\":true,\"shifts_applied\":",
                          "\"by_layer\":[{\"from_m\":0.10,\"to_m\":0.70,\"walls\":{\"iou\":",
                          "\"iou_by_unknown_below\":{\"0.05\":{\"iou\":",
                          "\"resolution_m\":0.100,",
                          "\"durable_state\":{\"bytes\":",
                          "\"round_trip_exact\":true",
                          "\"committed_snapshot\":{\"key_frames\":",
                          "\"grid_window\":{\"side_m\":8.0,\"cells\":",
                          "\"baseline_cells\":",
                          "\"pmap_window\":{\"side_m\":8.0,\"segments\":",
                          "\"baseline_segments\":"}) {
    EXPECT_NE(figures.find(key), std::string::npos) << key << " missing in " << figures;
  }
  EXPECT_EQ(figures.find("null"), std::string::npos) << figures;

  const std::string pmap = Slurp(dir / "out" / "pmap.json");
  EXPECT_NE(pmap.find("\"segments\":[{\"id\":"), std::string::npos);
  EXPECT_NE(pmap.find("\"path\":[["), std::string::npos);
  EXPECT_NE(pmap.find("\"boundary\":["), std::string::npos);
  const std::string pgm = Slurp(dir / "out" / "grid.pgm");
  EXPECT_EQ(pgm.substr(0, 3), "P5\n");
  const std::string yaml = Slurp(dir / "out" / "grid.yaml");
  for (const char* key : {"image: grid.pgm", "resolution:", "origin: [", "negate: 0",
                          "occupied_thresh:", "free_thresh:"}) {
    EXPECT_NE(yaml.find(key), std::string::npos) << key;
  }
  const std::string poses = Slurp(dir / "out" / "poses.csv");
  EXPECT_EQ(poses.rfind("#timestamp [ns],x [m],y [m],theta [rad]\n", 0), 0u);
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "pmap.svg"));
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "grid.png"));

  // A map compared with itself has the same shape.
  const std::string again = bench.string() + " maps --no-variants --dataset " +
                            (dir / "data").string() + " --out " + (dir / "out2").string() +
                            " --json --compare " + (dir / "out" / "pmap.json").string() + " > " +
                            (dir / "figures2.txt").string();
  ASSERT_EQ(std::system(again.c_str()), 0) << again;
  EXPECT_NE(Slurp(dir / "figures2.txt").find("\"shape_similarity\":1.0000"), std::string::npos)
      << Slurp(dir / "figures2.txt");

  // Heading correction alone: no correlation ran, no shift was applied.
  const std::string no_corr = bench.string() +
                              " maps --no-variants --no-map-correlation --dataset " +
                              (dir / "data").string() + " --out " + (dir / "out4").string() +
                              " --json > " + (dir / "figures4.txt").string();
  ASSERT_EQ(std::system(no_corr.c_str()), 0) << no_corr;
  const std::string figures4 = Slurp(dir / "figures4.txt");
  EXPECT_NE(figures4.find("\"correlation\":{\"enabled\":false,\"shifts_applied\":0}"),
            std::string::npos)
      << figures4;
  EXPECT_NE(figures4.find("\"registrations\":0,"), std::string::npos) << figures4;

  // The grid's cell size is the bench's to choose; a nonsensical one is refused by the grid.
  const std::string coarse = bench.string() +
                             " maps --no-variants --grid-resolution 0.2 --dataset " +
                             (dir / "data").string() + " --out " + (dir / "out5").string() +
                             " --json > " + (dir / "figures5.txt").string();
  ASSERT_EQ(std::system(coarse.c_str()), 0) << coarse;
  EXPECT_NE(Slurp(dir / "figures5.txt").find("\"resolution_m\":0.200,"), std::string::npos)
      << Slurp(dir / "figures5.txt");
  // Refused runs on this dataset: a non-zero exit and the reason on stderr.
  const auto refused = [&](const std::string& args, const std::string& name,
                           const std::string& reason) {
    const std::string cmd = bench.string() + " maps " + args + " --dataset " +
                            (dir / "data").string() + " --out " + (dir / name).string() + " 2> " +
                            (dir / (name + ".err")).string();
    EXPECT_NE(std::system(cmd.c_str()), 0) << cmd;
    const std::string err = Slurp(dir / (name + ".err"));
    EXPECT_NE(err.find(reason), std::string::npos) << cmd << ": " << err;
  };
  refused("--grid-resolution -0.1", "out6", "resolution_m must be positive");
  // --true-depth needs the true disparity of every key frame; this dataset has none.
  refused("--true-depth", "out7", "has no gt_disparity0");

  // A folder that is not a mobile-base dataset is refused with a reason.
  const std::string bad = bench.string() + " maps --dataset " + dir.string() + " --out " +
                          (dir / "out3").string() + " 2> " + (dir / "err.txt").string();
  EXPECT_NE(std::system(bad.c_str()), 0);
  EXPECT_NE(Slurp(dir / "err.txt").find("epmap-bench maps:"), std::string::npos);
  std::filesystem::remove_all(dir);
}

// `epmap-bench edges` on a short stretch of the building route with the true disparity of every
// frame: both disparity estimates are scored in every range bin, and the edge points of this
// world's textures are accurate to a fraction of a pixel. A run without truth is refused.
TEST(EdgesBench, ScoresEdgeDisparitiesAgainstTheTruth) {
  const auto dir = testing::FreshTempDir("edges-bench");
  const std::string record = (testing::BinDir() / "epmap-sim").string() +
                             " record --scenario building --frames 8 --disparity-every-frame "
                             "--out " +
                             (dir / "data").string() + " 2> /dev/null";
  ASSERT_EQ(std::system(record.c_str()), 0) << record;
  const auto bench = testing::BinDir() / "epmap-bench";
  const std::string cmd = bench.string() + " edges --dataset " + (dir / "data").string() + " > " +
                          (dir / "edges.json").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const std::string json = Slurp(dir / "edges.json");
  EXPECT_NE(json.find("\"frames\":8,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"disparity\":\"edge locations (default)\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"disparity\":\"refined over the window"), std::string::npos) << json;
  // The near bin (>= 12 px) of the default: its median error is well under a pixel.
  const size_t near = json.find("\">=12 (near)\"");
  ASSERT_NE(near, std::string::npos) << json;
  const size_t key = json.find("\"median_abs_error_px\":", near);
  ASSERT_NE(key, std::string::npos);
  const double median =
      std::atof(json.c_str() + key + std::string("\"median_abs_error_px\":").size());
  EXPECT_GT(median, 0.0) << json;
  EXPECT_LT(median, 0.5) << json;

  // The range cut of the perceptual map (20 m) is applied before scoring: a 5 m cut keeps fewer
  // matched edge points.
  const auto matched = [](const std::string& j) {
    const std::string name = "\"matched\":";
    const size_t key = j.find(name);
    return key == std::string::npos ? -1L : std::atol(j.c_str() + key + name.size());
  };
  const std::string cut = bench.string() + " edges --max-range 5 --dataset " +
                          (dir / "data").string() + " > " + (dir / "edges5.json").string();
  ASSERT_EQ(std::system(cut.c_str()), 0) << cut;
  const std::string json5 = Slurp(dir / "edges5.json");
  EXPECT_GT(matched(json5), 0) << json5;
  EXPECT_LT(matched(json5), matched(json)) << json5;
  const std::string no_range =
      RefusalOf("edges --max-range 0 --dataset " + (dir / "data").string(), dir);
  EXPECT_NE(no_range.find("max_range_m must be > 0"), std::string::npos) << no_range;

  // The planar test world has no true disparity: a clear error.
  testing::WriteRunDataset(testing::PlanarWorld(testing::RoomWalls()),
                           testing::SimulateRun({{1.0, 1.0}, {2.0, 1.0}}, 0.0, {}), dir / "plain");
  const std::string bad = RefusalOf("edges --dataset " + (dir / "plain").string(), dir);
  EXPECT_NE(bad.find("no gt_disparity0"), std::string::npos) << bad;
  std::filesystem::remove_all(dir);
}

// `epmap-bench boundary`: the indexed boundary and the baseline's, per path length, identical
// (the command fails otherwise); a length out of range is refused by name.
TEST(BoundaryBench, TimesTheIndexedBoundaryBesideComparingEverything) {
  const auto dir = testing::FreshTempDir("boundary-bench");
  const auto bench = testing::BinDir() / "epmap-bench";
  const std::string cmd = bench.string() + " boundary --lengths 60,400 --revisits 3 --repeat 1 > " +
                          (dir / "boundary.json").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const std::string json = Slurp(dir / "boundary.json");
  for (const char* key :
       {"\"path_m\":60,\"passes\":1,\"objects\":122,", "\"path_m\":400,",
        "\"path_m\":750,\"passes\":3,\"objects\":1502,", "\"indexed_ms_median\":",
        "\"baseline_ms_median\":", "\"ratio_to_baseline\":", "\"all_same\":true"}) {
    EXPECT_NE(json.find(key), std::string::npos) << key << " missing in " << json;
  }
  EXPECT_EQ(json.find("\"same_boundary\":false"), std::string::npos) << json;
  EXPECT_EQ(json.find("null"), std::string::npos) << json;
  const std::string bad = RefusalOf("boundary --lengths 1", dir);
  EXPECT_NE(bad.find("--lengths must be within"), std::string::npos) << bad;
}

// --pmap: the same timing on a map a run built (pmap.json's layout), every segment and path
// point read; a file that holds no perceptual map is refused by name.
TEST(BoundaryBench, TimesAPerceptualMapARunBuilt) {
  const auto dir = testing::FreshTempDir("boundary-bench-pmap");
  const auto bench = testing::BinDir() / "epmap-bench";
  {
    // A corridor: walls 1.5 m either side of an 11-point path, one object across the path.
    std::ofstream f(dir / "pmap.json");
    f << "{\"frame\":\"world\",\"segments\":[";
    uint32_t id = 1;
    for (int x = 0; x < 10; ++x) {
      for (const double y : {-1.5, 1.5}) {
        f << (id > 1 ? "," : "") << "{\"id\":" << id << ",\"x1\":" << x << ".0,\"y1\":" << y
          << ",\"x2\":" << x + 1 << ".0,\"y2\":" << y << ",\"view\":1,\"observations\":1}";
        ++id;
      }
    }
    f << ",{\"id\":" << id << ",\"x1\":5.0,\"y1\":-0.5,\"x2\":5.0,\"y2\":5e-1}],\"path\":[";
    for (int x = 0; x <= 10; ++x) f << (x ? "," : "") << "[" << x << ".0,-0.0]";
    f << "],\"boundary\":[[0.0,1.5]]}";
  }
  const std::string cmd = bench.string() +
                          " boundary --lengths 60 --revisits 1 --repeat 1 --pmap " +
                          (dir / "pmap.json").string() + " > " + (dir / "boundary.json").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const std::string json = Slurp(dir / "boundary.json");
  EXPECT_NE(json.find("\"path_points\":11,\"objects\":21,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"all_same\":true"), std::string::npos) << json;
  {
    std::ofstream f(dir / "empty.json");
    f << "{\"segments\":[],\"path\":[]}";
  }
  const std::string bad =
      RefusalOf("boundary --lengths 60 --revisits 1 --pmap " + (dir / "empty.json").string(), dir);
  EXPECT_NE(bad.find("holds no perceptual map"), std::string::npos) << bad;
}

}  // namespace
}  // namespace epmap
