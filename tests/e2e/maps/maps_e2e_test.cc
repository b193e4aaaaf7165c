// Mobile-base maps end to end (issue 6): a short run through the synthetic building is
// recorded (for its ground truth and URDF) and published over DDS by epmap-sim to a real
// epmapd on this test's own domain; epmapctl, run as a process, writes the perceptual map
// (JSON, SVG), the occupancy grid (PGM + map_server YAML, PNG) and the pose, which are checked
// against the ground truth. A layer that does not exist is INVALID_ARGUMENT; before any
// odometry the maps are FAILED_PRECONDITION.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "common/dataset/dataset.h"
#include "perception/mobile_mapping/map_evaluation.h"
#include "tests/support/epmapd_fixture.h"

namespace epmap {
namespace {

using mobile_mapping::Segment2;

constexpr int kFrames = 150;  // ~15 s at the scenario's 10 Hz: out of the start room, ~5 m

std::string ReadText(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

Eigen::Isometry2d Pose(double x, double y, double theta) {
  return Eigen::Translation2d(x, y) * Eigen::Rotation2Dd(theta);
}

std::pair<int, std::string> Ctl(const testing::Epmapd& epmapd, const std::filesystem::path& work,
                                std::vector<std::string> args) {
  args.insert(args.begin(), {"--server", epmapd.address()});
  return testing::RunToCompletion(testing::BinDir() / "epmapctl", args, work / "ctl.log",
                                  std::chrono::seconds(30));
}

TEST(MapsE2E, BuildingRunGivesMapsNearTheTrueWalls) {
  const auto work = testing::FreshTempDir("maps-e2e");
  const uint32_t domain = testing::UniqueDomainId(61);

  // The same run (same seed) recorded: its URDF for epmapd, its ground truth for the checks.
  const auto rec = work / "rec";
  const auto [rec_code, rec_out] =
      testing::RunToCompletion(testing::BinDir() / "epmap-sim",
                               {"record", "--scenario", "building", "--frames",
                                std::to_string(kFrames), "--out", rec.string()},
                               work / "record.log", std::chrono::seconds(60));
  ASSERT_EQ(rec_code, 0) << rec_out;
  const auto data = dataset::Load(rec);
  ASSERT_TRUE(data.urdf.has_value());
  ASSERT_FALSE(data.walls.empty());
  ASSERT_FALSE(data.odometry.empty());

  testing::Epmapd epmapd(domain, {"--urdf", data.urdf->string()}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();

  // No odometry yet: not a mobile base, so no maps (a clear precondition, not a crash).
  {
    const auto [code, out] = Ctl(epmapd, work, {"pose"});
    EXPECT_NE(code, 0);
    EXPECT_NE(out.find("FAILED_PRECONDITION"), std::string::npos) << out;
  }

  const auto [pub_code, pub_out] =
      testing::RunToCompletion(testing::BinDir() / "epmap-sim",
                               {"publish", "--scenario", "building", "--frames",
                                std::to_string(kFrames), "--domain", std::to_string(domain)},
                               work / "publish.log", std::chrono::seconds(90));
  ASSERT_EQ(pub_code, 0) << pub_out;
  // Until the queue has drained and the pipeline is idle.
  uint64_t last = ~0ull;
  const auto status = epmapd.WaitStatus(
      [&](const v1::ServiceStatus& s) {
        const bool idle = s.queue_depth() == 0 && s.frames_processed() == last;
        last = s.frames_processed();
        return idle;
      },
      std::chrono::seconds(30));
  EXPECT_EQ(status.mode(), "mobile-base");
  const uint64_t key_frames = testing::Epmapd::Count(status.events(), "maps_key_frames");
  EXPECT_GE(key_frames, 10u) << status.DebugString();
  for (const auto& c : status.rejected_by_reason()) {
    // Good input: no key frame refused by the maps.
    EXPECT_NE(c.reason().rfind("maps:", 0), 0u) << c.reason() << " " << c.count();
  }

  // Ground truth in the world frame of the maps (the start pose = the odometry frame).
  const auto gt0 = dataset::InterpolatePlanar(data.gt_base_pose, data.odometry.front().stamp_ns);
  ASSERT_TRUE(gt0.has_value());
  const auto& o0 = data.odometry.front();
  const Eigen::Isometry2d T_start_gt =
      (Pose(gt0->x, gt0->y, gt0->theta) * Pose(o0.x, o0.y, o0.theta).inverse()).inverse();
  std::vector<Segment2> walls;
  for (const auto& w : data.walls) {
    walls.push_back(
        {T_start_gt * Eigen::Vector2d(w.x1, w.y1), T_start_gt * Eigen::Vector2d(w.x2, w.y2)});
  }

  // Perceptual map: segments in the world frame, most of their length near true walls (the
  // rest is furniture and door frames).
  {
    const auto [code, out] = Ctl(epmapd, work, {"pmap", "--out", (work / "map.json").string()});
    ASSERT_EQ(code, 0) << out << epmapd.process().Output();
    const YAML::Node map = YAML::Load(ReadText(work / "map.json"));
    std::vector<Segment2> segments;
    for (const auto& s : map["segments"]) {
      segments.push_back({{s["x1"].as<double>(), s["y1"].as<double>()},
                          {s["x2"].as<double>(), s["y2"].as<double>()}});
    }
    ASSERT_GE(segments.size(), 5u);
    EXPECT_GE(map["path"].size(), 2u);
    const double near_walls = mobile_mapping::CoveredShare(segments, walls, 1.0);
    std::printf("perceptual map: %zu segments, %.0f%% of their length within 1 m of a wall\n",
                segments.size(), 100 * near_walls);
    EXPECT_GE(near_walls, 0.6);
    const auto [svg_code, svg_out] =
        Ctl(epmapd, work, {"pmap", "--out", (work / "map.svg").string()});
    ASSERT_EQ(svg_code, 0) << svg_out;
    EXPECT_NE(ReadText(work / "map.svg").find("<svg"), std::string::npos);
  }

  // Occupancy grid: PGM + YAML as map_server loads them; occupied cells near true walls.
  {
    const auto pgm = work / "grid.pgm";
    const auto [code, out] = Ctl(epmapd, work, {"grid", "--out", pgm.string()});
    ASSERT_EQ(code, 0) << out;
    const YAML::Node yaml = YAML::LoadFile((work / "grid.yaml").string());
    EXPECT_EQ(yaml["image"].as<std::string>(), "grid.pgm");
    const double resolution = yaml["resolution"].as<double>();
    EXPECT_GT(resolution, 0.0);
    ASSERT_EQ(yaml["origin"].size(), 3u);
    EXPECT_EQ(yaml["negate"].as<int>(), 0);
    const double occupied_thresh = yaml["occupied_thresh"].as<double>();
    EXPECT_GT(occupied_thresh, yaml["free_thresh"].as<double>());
    const cv::Mat image = cv::imread(pgm.string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(image.empty());
    ASSERT_EQ(image.type(), CV_8UC1);
    // map_server: p = (255 - value) / 255 with negate 0; the image's top row is the largest y.
    const double ox = yaml["origin"][0].as<double>(), oy = yaml["origin"][1].as<double>();
    std::vector<Segment2> occupied;
    for (int r = 0; r < image.rows; ++r) {
      for (int c = 0; c < image.cols; ++c) {
        if ((255.0 - image.at<uint8_t>(r, c)) / 255.0 <= occupied_thresh) continue;
        const Eigen::Vector2d centre(ox + (c + 0.5) * resolution,
                                     oy + (image.rows - r - 0.5) * resolution);
        occupied.push_back({centre, centre});
      }
    }
    ASSERT_GE(occupied.size(), 20u);
    size_t near = 0;
    for (const auto& cell : occupied) {
      near += mobile_mapping::CoveredShare({{cell.a, cell.a + Eigen::Vector2d(1e-3, 0)}}, walls,
                                           0.3) > 0.5;
    }
    const double share = static_cast<double>(near) / occupied.size();
    std::printf("grid: %dx%d cells of %.2f m, %zu occupied, %.0f%% within 0.3 m of a wall\n",
                image.cols, image.rows, resolution, occupied.size(), 100 * share);
    EXPECT_GE(share, 0.5);

    const auto [png_code, png_out] =
        Ctl(epmapd, work, {"grid", "--out", (work / "grid.png").string(), "--layer", "0"});
    EXPECT_EQ(png_code, 0) << png_out;
    EXPECT_FALSE(cv::imread((work / "grid.png").string()).empty());
    const auto [bad_code, bad_out] =
        Ctl(epmapd, work, {"grid", "--out", (work / "bad.pgm").string(), "--layer", "99"});
    EXPECT_NE(bad_code, 0);
    EXPECT_NE(bad_out.find("INVALID_ARGUMENT"), std::string::npos) << bad_out;
    EXPECT_NE(bad_out.find("layer 99"), std::string::npos) << bad_out;
  }

  // Pose: the corrected pose near the truth at the same odometry reading, difference finite.
  {
    const auto [code, out] = Ctl(epmapd, work, {"pose", "--json"});
    ASSERT_EQ(code, 0) << out;
    const YAML::Node pose = YAML::Load(out);
    const auto odo = pose["odometry"], cor = pose["corrected"], diff = pose["difference"];
    for (const auto* k : {"x", "y", "theta"}) {
      EXPECT_TRUE(std::isfinite(diff[k].as<double>())) << out;
    }
    EXPECT_LT(std::abs(diff["theta"].as<double>()), 0.1) << out;
    EXPECT_GE(pose["keyframes"].as<uint64_t>(), key_frames > 0 ? 1u : 0u);
    // Publish and record share the seed: the recorded frame with this odometry reading is the
    // moment of the served pose (their stamps differ: publish uses the wall clock).
    const Eigen::Vector2d served_odo(odo["x"].as<double>(), odo["y"].as<double>());
    size_t best = 0;
    for (size_t i = 0; i < data.odometry.size(); ++i) {
      const auto& o = data.odometry[i];
      if ((Eigen::Vector2d(o.x, o.y) - served_odo).norm() <
          (Eigen::Vector2d(data.odometry[best].x, data.odometry[best].y) - served_odo).norm()) {
        best = i;
      }
    }
    const auto gt = dataset::InterpolatePlanar(data.gt_base_pose, data.odometry[best].stamp_ns);
    ASSERT_TRUE(gt.has_value());
    const Eigen::Isometry2d truth = T_start_gt * Pose(gt->x, gt->y, gt->theta);
    const Eigen::Vector2d corrected(cor["x"].as<double>(), cor["y"].as<double>());
    const double position_error = (corrected - truth.translation()).norm();
    const double heading_error = std::abs(std::remainder(
        cor["theta"].as<double>() - std::atan2(truth.linear()(1, 0), truth.linear()(0, 0)),
        2 * std::numbers::pi));
    std::printf("pose: corrected %.3f m and %.2f deg from the truth\n", position_error,
                heading_error * 180 / std::numbers::pi);
    EXPECT_LT(position_error, 0.3) << out;
    EXPECT_LT(heading_error, 2.0 * std::numbers::pi / 180) << out;
  }
}

}  // namespace
}  // namespace epmap
