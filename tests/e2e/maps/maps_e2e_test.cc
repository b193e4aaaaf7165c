// Mobile-base maps end to end (issue 6): a short run through the synthetic building is
// recorded (for its ground truth and URDF) and published over DDS by epmap-sim to a real
// epmapd on this test's own domain; epmapctl, run as a process, writes the perceptual map
// (JSON, SVG), the occupancy grid (PGM + map_server YAML, PNG) and the pose, which are checked
// against the ground truth. A layer that does not exist is INVALID_ARGUMENT; before any
// odometry the maps are FAILED_PRECONDITION.

#include <epmap_dds/CameraInfoPubSubTypes.h>
#include <epmap_dds/ImagePubSubTypes.h>
#include <epmap_dds/JointStatePubSubTypes.h>
#include <epmap_dds/MarkerArrayPubSubTypes.h>
#include <epmap_dds/OccupancyGridPubSubTypes.h>
#include <epmap_dds/OdometryPubSubTypes.h>
#include <epmap_dds/TFMessagePubSubTypes.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <fstream>
#include <functional>
#include <future>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "common/dataset/dataset.h"
#include "common/dds/endpoints.h"
#include "common/dds/participant.h"
#include "common/dds/ros_conversions.h"
#include "common/dds/topics.h"
#include "perception/mobile_mapping/map_evaluation.h"
#include "perception/perceptual_map/map_window.h"
#include "tests/support/building_run.h"
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

std::pair<int, std::string> Ctl(const testing::Epmapd& epmapd, const std::filesystem::path& work,
                                std::vector<std::string> args) {
  args.insert(args.begin(), {"--server", epmapd.address()});
  return testing::RunToCompletion(testing::BinDir() / "epmapctl", args, work / "ctl.log",
                                  std::chrono::seconds(30));
}

// The grid on rt/map as a ROS planner that joins now gets it (latched: transient local), once
// one with `stamp_ns` has come; nullopt after `timeout`.
std::optional<nav_msgs::msg::OccupancyGrid> LatchedGridWithStamp(uint32_t domain, int64_t stamp_ns,
                                                                 std::chrono::seconds timeout) {
  dds::Participant ros_side(domain, "maps-e2e-map-reader");
  std::mutex map_mutex;
  std::optional<nav_msgs::msg::OccupancyGrid> latched;
  dds::Reader<nav_msgs::msg::OccupancyGrid, nav_msgs::msg::OccupancyGridPubSubType> map_reader(
      ros_side, "rt/map",
      [&](nav_msgs::msg::OccupancyGrid&& m) {
        std::lock_guard lock(map_mutex);
        latched = std::move(m);
      },
      16u << 20, 1, dds::Durability::kTransientLocal);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard lock(map_mutex);
      if (latched && dds::ToNanoseconds(latched->header().stamp()) == stamp_ns) return latched;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return std::nullopt;
}

TEST(MapsE2E, BuildingRunGivesMapsNearTheTrueWalls) {
  const auto work = testing::FreshTempDir("maps-e2e");
  const uint32_t domain = testing::UniqueDomainId(61);

  // The same run (same seed) recorded: its URDF for epmapd, its ground truth for the checks.
  dataset::Dataset data;
  ASSERT_NO_FATAL_FAILURE(testing::RecordBuilding(work, kFrames, &data));

  // A grid cell size other than the default, to see the configuration reach the grid.
  constexpr double kGridResolution = 0.125;
  {
    std::ofstream config(work / "epmapd.yaml");
    config << "maps:\n  grid_resolution_m: " << kGridResolution << "\n";
  }
  testing::Epmapd epmapd(
      domain, {"--urdf", data.urdf->string(), "--config", (work / "epmapd.yaml").string()}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();

  // A ROS 2 node's view: map -> odom on rt/tf as it is published (tf is volatile: listen first).
  dds::Participant ros_side(domain, "maps-e2e-ros-side");
  std::mutex tf_mutex;
  std::optional<tf2_msgs::msg::TFMessage> last_tf;
  size_t tf_messages = 0;
  dds::Reader<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType> tf_reader(
      ros_side, "rt/tf",
      [&](tf2_msgs::msg::TFMessage&& m) {
        std::lock_guard lock(tf_mutex);
        last_tf = std::move(m);
        ++tf_messages;
      },
      1u << 20, 100);

  // No odometry yet: not a mobile base, so no maps (a clear precondition, not a crash).
  {
    const auto [code, out] = Ctl(epmapd, work, {"pose"});
    EXPECT_NE(code, 0);
    EXPECT_NE(out.find("FAILED_PRECONDITION"), std::string::npos) << out;
  }

  v1::ServiceStatus status;
  ASSERT_NO_FATAL_FAILURE(
      testing::PublishBuildingUntilIdle(epmapd, domain, work, kFrames, &status));
  EXPECT_EQ(status.mode(), "mobile-base");
  const uint64_t key_frames = testing::Epmapd::Count(status.events(), "maps_key_frames");
  EXPECT_GE(key_frames, 10u) << status.DebugString();
  // Good input: no key frame refused by the maps.
  EXPECT_EQ(status.key_frames_refused(), 0u) << status.DebugString();

  // Ground truth in the world frame of the maps (the start pose = the odometry frame).
  Eigen::Isometry2d T_start_gt;
  ASSERT_NO_FATAL_FAILURE(testing::GroundTruthToMaps(data, &T_start_gt));
  std::vector<Segment2> walls;
  for (const auto& [a, b] : testing::WallsInMaps(data, T_start_gt)) walls.push_back({a, b});

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
    // Paper 003's redundancy removal (III-D): each segment says whether it keeps it, and
    // --kept-only serves just those (the clean map of its Fig. 10), the same ones.
    std::set<uint32_t> kept_ids;
    for (const auto& s : map["segments"]) {
      if (s["kept"].as<bool>()) kept_ids.insert(s["id"].as<uint32_t>());
    }
    EXPECT_EQ(map["segments_in_map"].as<size_t>(), segments.size());
    EXPECT_GT(kept_ids.size(), 0u);
    EXPECT_LT(kept_ids.size(), segments.size());
    const auto [kept_code, kept_out] =
        Ctl(epmapd, work, {"pmap", "--kept-only", "--out", (work / "kept.json").string()});
    ASSERT_EQ(kept_code, 0) << kept_out;
    const YAML::Node kept = YAML::Load(ReadText(work / "kept.json"));
    std::set<uint32_t> served_ids;
    for (const auto& s : kept["segments"]) {
      EXPECT_TRUE(s["kept"].as<bool>());
      served_ids.insert(s["id"].as<uint32_t>());
    }
    if (kept["stamp_ns"].as<int64_t>() == map["stamp_ns"].as<int64_t>()) {  // the same maps
      EXPECT_EQ(served_ids, kept_ids);
      EXPECT_EQ(kept["segments_in_map"].as<size_t>(), segments.size());
    }
    std::printf("redundancy removal keeps %zu of %zu segments\n", kept_ids.size(), segments.size());
    const auto [svg_code, svg_out] =
        Ctl(epmapd, work, {"pmap", "--out", (work / "map.svg").string()});
    ASSERT_EQ(svg_code, 0) << svg_out;
    EXPECT_NE(ReadText(work / "map.svg").find("<svg"), std::string::npos);
  }

  // The perceptual map is built by its first reader (the pmap calls above, the ROS publisher):
  // the status shows what the readers paid, beside the mapping thread's stages.
  {
    const auto read_stage = [](const v1::ServiceStatus& st) -> const v1::StageTiming* {
      for (const auto& t : st.stages()) {
        if (t.stage() == "maps.perceptual_read") return &t;
      }
      return nullptr;
    };
    const auto st =
        epmapd.WaitStatus([&](const v1::ServiceStatus& s) { return read_stage(s) != nullptr; },
                          std::chrono::seconds(10));
    const auto* t = read_stage(st);
    ASSERT_NE(t, nullptr) << st.DebugString();
    EXPECT_GE(t->samples(), 1u);
    EXPECT_GT(t->median_ms(), 0.0);
    std::printf("maps.perceptual_read: %llu builds, median %.2f ms\n",
                static_cast<unsigned long long>(t->samples()), t->median_ms());
  }

  // Occupancy grid: PGM + YAML as map_server loads them; occupied cells near true walls.
  {
    const auto pgm = work / "grid.pgm";
    const auto [code, out] = Ctl(epmapd, work, {"grid", "--out", pgm.string()});
    ASSERT_EQ(code, 0) << out;
    const YAML::Node yaml = YAML::LoadFile((work / "grid.yaml").string());
    EXPECT_EQ(yaml["image"].as<std::string>(), "grid.pgm");
    const double resolution = yaml["resolution"].as<double>();
    EXPECT_DOUBLE_EQ(resolution, kGridResolution);
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

    // What a robot 0.5 m tall can hit: the lowest band alone. Over every band (a robot taller
    // than the top band): the combined map, byte for byte.
    const auto [low_code, low_out] =
        Ctl(epmapd, work, {"grid", "--out", (work / "low.pgm").string(), "--max-height", "0.5"});
    ASSERT_EQ(low_code, 0) << low_out;
    EXPECT_NE(low_out.find("layers 0-0 combined (0.10-0.70 m)"), std::string::npos) << low_out;
    EXPECT_FALSE(cv::imread((work / "low.pgm").string(), cv::IMREAD_UNCHANGED).empty());
    const auto grid_below = [&](std::optional<double> max_height_m) {
      grpc::ClientContext context;
      v1::GetOccupancyGridRequest request;
      if (max_height_m) request.set_max_height_m(*max_height_m);
      v1::OccupancyGrid grid;
      EXPECT_TRUE(epmapd.stub().GetOccupancyGrid(&context, request, &grid).ok());
      return grid;
    };
    const v1::OccupancyGrid all = grid_below(std::nullopt), tall = grid_below(5.0),
                            low = grid_below(0.5);
    EXPECT_EQ(all.combined_layers(), 3u);
    EXPECT_EQ(tall.combined_layers(), 3u);
    EXPECT_EQ(tall.occupancy(), all.occupancy());
    EXPECT_EQ(low.combined_layers(), 1u);
    EXPECT_TRUE(low.combined());
    EXPECT_NE(low.occupancy(), all.occupancy()) << "desks and chairs stand above 0.7 m";
    const auto [both_code, both_out] =
        Ctl(epmapd, work,
            {"grid", "--out", (work / "both.pgm").string(), "--layer", "0", "--max-height", "0.5"});
    EXPECT_NE(both_code, 0) << both_out;
    EXPECT_FALSE(std::filesystem::exists(work / "both.pgm"));
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
    const Eigen::Isometry2d truth = T_start_gt * testing::PlanarPose(gt->x, gt->y, gt->theta);
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

  // The same maps for ROS 2 planners on DDS. rt/map is latched (transient local, as
  // map_server): a reader that joins now still gets the newest grid, and it is the grid
  // GetOccupancyGrid serves (-1 where the export says unknown). rt/tf: map -> odom, the
  // correction GetPose reports.
  {
    grpc::ClientContext context;
    v1::OccupancyGrid served;
    ASSERT_TRUE(epmapd.stub().GetOccupancyGrid(&context, {}, &served).ok());
    const auto grid = LatchedGridWithStamp(domain, served.stamp_ns(), std::chrono::seconds(15));
    ASSERT_TRUE(grid.has_value()) << "no grid with the served stamp on rt/map";
    EXPECT_EQ(grid->header().frame_id(), "map");
    EXPECT_EQ(grid->info().width(), served.width());
    EXPECT_EQ(grid->info().height(), served.height());
    EXPECT_FLOAT_EQ(grid->info().resolution(), static_cast<float>(served.resolution_m()));
    EXPECT_DOUBLE_EQ(grid->info().origin().position().x(), served.origin().x());
    EXPECT_DOUBLE_EQ(grid->info().origin().position().y(), served.origin().y());
    ASSERT_EQ(grid->data().size(), served.occupancy().size());
    size_t mismatched = 0, unknown = 0, occupied = 0;
    for (size_t i = 0; i < grid->data().size(); ++i) {
      const auto byte = static_cast<uint8_t>(served.occupancy()[i]);
      const int want = byte == 255 ? -1 : byte;
      mismatched += grid->data()[i] != want;
      unknown += grid->data()[i] == -1;
      occupied += grid->data()[i] >= 65;
    }
    EXPECT_EQ(mismatched, 0u);
    EXPECT_GT(unknown, 0u);
    EXPECT_GT(occupied, 20u);
    std::printf("rt/map: %ux%u, %zu unknown, %zu occupied (>= 65), same as GetOccupancyGrid\n",
                grid->info().width(), grid->info().height(), unknown, occupied);

    // The perceptual map for RViz, latched too: the segments GetPerceptualMap serves, end for
    // end, and the path.
    grpc::ClientContext pmap_context;
    v1::PerceptualMap pmap;
    ASSERT_TRUE(epmapd.stub().GetPerceptualMap(&pmap_context, {}, &pmap).ok());
    std::mutex markers_mutex;
    std::optional<visualization_msgs::msg::MarkerArray> markers;
    dds::Reader<visualization_msgs::msg::MarkerArray,
                visualization_msgs::msg::MarkerArrayPubSubType>
        markers_reader(
            ros_side, "rt/epmap/perceptual_map",
            [&](visualization_msgs::msg::MarkerArray&& m) {
              std::lock_guard lock(markers_mutex);
              if (m.markers().size() > 1 &&
                  dds::ToNanoseconds(m.markers()[1].header().stamp()) == pmap.stamp_ns()) {
                markers = std::move(m);
              }
            },
            16u << 20, 1, dds::Durability::kTransientLocal);
    const auto markers_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
    while (std::chrono::steady_clock::now() < markers_deadline) {
      {
        std::lock_guard lock(markers_mutex);
        if (markers) break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    std::lock_guard markers_lock(markers_mutex);
    ASSERT_TRUE(markers.has_value()) << "no perceptual map with the served stamp";
    EXPECT_EQ(markers->markers()[0].action(), 3) << "DELETEALL first";
    const auto find = [&](const std::string& ns) -> const visualization_msgs::msg::Marker* {
      for (const auto& m : markers->markers()) {
        if (m.ns() == ns) return &m;
      }
      return nullptr;
    };
    const auto* lines = find("segments");
    ASSERT_NE(lines, nullptr);
    EXPECT_EQ(lines->type(), 5);  // LINE_LIST
    EXPECT_EQ(lines->header().frame_id(), "map");
    ASSERT_EQ(lines->points().size(), 2u * static_cast<size_t>(pmap.segments_size()));
    double worst = 0;
    for (int i = 0; i < pmap.segments_size(); ++i) {
      const auto& s = pmap.segments(i);
      const auto& a = lines->points()[2 * static_cast<size_t>(i)];
      const auto& b = lines->points()[2 * static_cast<size_t>(i) + 1];
      worst = std::max({worst, std::abs(a.x() - s.x1()), std::abs(a.y() - s.y1()),
                        std::abs(b.x() - s.x2()), std::abs(b.y() - s.y2())});
    }
    EXPECT_LT(worst, 1e-9);
    // The kept ones again, as GetPerceptualMap marks them.
    const auto* kept_lines = find("kept_segments");
    ASSERT_NE(kept_lines, nullptr);
    const auto kept = std::count_if(pmap.segments().begin(), pmap.segments().end(),
                                    [](const v1::MapSegment& s) { return s.kept(); });
    EXPECT_GT(kept, 0);
    EXPECT_EQ(kept_lines->points().size(), 2u * static_cast<size_t>(kept));
    const auto* path = find("path");
    ASSERT_NE(path, nullptr);
    EXPECT_EQ(path->points().size(), static_cast<size_t>(pmap.path_size()));
    std::printf("%s: %zu markers, %d segments, %zu path points, as GetPerceptualMap\n",
                "rt/epmap/perceptual_map", markers->markers().size(), pmap.segments_size(),
                path->points().size());

    grpc::ClientContext pose_context;
    v1::PoseEstimate pose;
    ASSERT_TRUE(epmapd.stub().GetPose(&pose_context, {}, &pose).ok());
    std::lock_guard lock(tf_mutex);
    ASSERT_TRUE(last_tf.has_value()) << "nothing on rt/tf";
    ASSERT_EQ(last_tf->transforms().size(), 1u);
    const auto& t = last_tf->transforms()[0];
    EXPECT_EQ(t.header().frame_id(), "map");
    EXPECT_EQ(t.child_frame_id(), "odom");
    // Stamped with the newest processed frame, not the key frame the correction comes from
    // (a lookup at sensor time must not extrapolate), and sent for every frame with maps.
    v1::ServiceStatus after;
    ASSERT_TRUE(epmapd.Status(&after).ok());
    EXPECT_EQ(dds::ToNanoseconds(t.header().stamp()), after.last_stamp_ns());
    EXPECT_GE(dds::ToNanoseconds(t.header().stamp()), pose.stamp_ns());
    EXPECT_GT(tf_messages, testing::Epmapd::Count(after.events(), "maps_key_frames"));
    EXPECT_GE(tf_messages, after.frames_processed() / 2);
    const Eigen::Isometry2d expected =
        testing::PlanarPose(pose.corrected().x(), pose.corrected().y(), pose.corrected().theta()) *
        testing::PlanarPose(pose.odometry().x(), pose.odometry().y(), pose.odometry().theta())
            .inverse();
    const auto& q = t.transform_value().rotation();
    const double yaw = 2 * std::atan2(q.z(), q.w());
    EXPECT_NEAR(t.transform_value().translation().x(), expected.translation().x(), 1e-3);
    EXPECT_NEAR(t.transform_value().translation().y(), expected.translation().y(), 1e-3);
    EXPECT_NEAR(
        std::remainder(yaw - Eigen::Rotation2Dd(expected.linear()).angle(), 2 * std::numbers::pi),
        0.0, 1e-3);
    EXPECT_NEAR(q.x() * q.x() + q.y() * q.y() + q.z() * q.z() + q.w() * q.w(), 1.0, 1e-9);
    std::printf("rt/tf: %zu map -> odom messages, the last (%.3f, %.3f) m, %.2f deg\n", tf_messages,
                t.transform_value().translation().x(), t.transform_value().translation().y(),
                yaw * 180 / std::numbers::pi);
  }
  // Kept for a look when something failed; 25 MB a run otherwise left in the temp dir.
  if (!HasFailure()) std::filesystem::remove_all(work);
}

// A hand-made robot on DDS: a textured plane 1 m ahead, odometry and the pan joint at every
// image stamp, so that single samples can be made bad.
class MobileBasePublisher {
 public:
  explicit MobileBasePublisher(uint32_t domain)
      : participant_(domain, "maps-bad-input-test"),
        left_(participant_, dds::TopicNames().left_image),
        right_(participant_, dds::TopicNames().right_image),
        left_info_(participant_, dds::TopicNames().left_info),
        right_info_(participant_, dds::TopicNames().right_info),
        joints_(participant_, dds::TopicNames().joints),
        odom_(participant_, dds::TopicNames().odom) {}

  bool WaitMatched() {
    const auto t = std::chrono::seconds(15);
    const bool ok = left_.WaitForReaders(1, t) && right_.WaitForReaders(1, t) &&
                    left_info_.WaitForReaders(1, t) && right_info_.WaitForReaders(1, t) &&
                    joints_.WaitForReaders(1, t) && odom_.WaitForReaders(1, t);
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    return ok;
  }

  // Another camera from the next frame on (its CameraInfo's focal length).
  void SetFocalLength(double px) { focal_px_ = px; }

  // The frames rt/odom names: by default those epmapd expects (maps.odom_frame, the URDF root).
  void SetOdometryFrames(std::string frame_id, std::string child_frame_id) {
    odom_frame_ = std::move(frame_id);
    odom_child_ = std::move(child_frame_id);
  }

  void Odometry(int64_t stamp, double x) {
    nav_msgs::msg::Odometry msg;
    dds::ToOdometry({stamp, x, 0.0, 0.0}, odom_frame_, odom_child_, &msg);
    odom_.Write(msg);
    Pace();
  }

  // One frame: odometry and pan at its stamp, then CameraInfo and the pair.
  void Frame(int64_t stamp, double x, double pan, bool blank) {
    Odometry(stamp, x);
    sensor_msgs::msg::JointState joints;
    dds::ToJointState({stamp, {"pan"}, {pan}}, &joints);
    joints_.Write(joints);
    Pace();
    sensor_msgs::msg::CameraInfo info;
    dds::ToCameraInfo(Camera(0.0), stamp, "cam0_optical", &info);
    left_info_.Write(info);
    dds::ToCameraInfo(Camera(kBaseline), stamp, "cam1_optical", &info);
    right_info_.Write(info);
    cv::Mat left(kHeight, kWidth, CV_8UC1, cv::Scalar(128)), right = left.clone();
    if (!blank) {
      // Vertical bars of random grey: a plane at fx B / d = 1 m (d = 10 px).
      cv::Mat wide(kHeight, kWidth + 20, CV_8UC1);
      cv::RNG rng(static_cast<uint64_t>(stamp));
      for (int c = 0; c < wide.cols;) {
        const int w = 3 + rng.uniform(0, 6);
        wide.colRange(c, std::min(wide.cols, c + w)).setTo(rng.uniform(30, 230));
        c += w;
      }
      cv::GaussianBlur(wide, wide, cv::Size(0, 0), 0.8);
      left = wide.colRange(10, 10 + kWidth).clone();
      right = wide.colRange(20, 20 + kWidth).clone();
    }
    sensor_msgs::msg::Image image;
    dds::MatToImage(left, stamp, "cam0_optical", &image);
    left_.Write(image);
    Pace();
    dds::MatToImage(right, stamp, "cam1_optical", &image);
    right_.Write(image);
    Pace();
  }

 private:
  static constexpr int kWidth = 160, kHeight = 120;
  static constexpr double kBaseline = 0.1;
  dds::CameraCalibration Camera(double baseline) const {
    return camera::Pinhole({kWidth, kHeight, focal_px_, focal_px_, kWidth / 2.0, kHeight / 2.0},
                           baseline);
  }
  static void Pace() { std::this_thread::sleep_for(std::chrono::milliseconds(20)); }

  std::string odom_frame_ = "odom", odom_child_ = "base_link";
  double focal_px_ = 100;

  dds::Participant participant_;
  dds::Writer<sensor_msgs::msg::Image, sensor_msgs::msg::ImagePubSubType> left_, right_;
  dds::Writer<sensor_msgs::msg::CameraInfo, sensor_msgs::msg::CameraInfoPubSubType> left_info_,
      right_info_;
  dds::Writer<sensor_msgs::msg::JointState, sensor_msgs::msg::JointStatePubSubType> joints_;
  dds::Writer<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType> odom_;
};

// epmapd with the building robot's URDF (pan limits +-2.6 rad, from a two-frame recording),
// fed frame by frame by a MobileBasePublisher.
class MapsFromPublishedFrames : public ::testing::Test {
 protected:
  // `edit_urdf`, if given, changes the recorded robot's URDF before epmapd loads it.
  // With `durable`, epmapd keeps its state (and so its maps) in <work>/state.
  void Start(const std::string& name, uint32_t domain_salt,
             const std::function<std::string(std::string)>& edit_urdf = {}, bool durable = false) {
    work_ = testing::FreshTempDir(name);
    const auto& work = work_;
    const uint32_t domain = testing::UniqueDomainId(domain_salt);
    const auto rec = work / "rec";
    const auto [rec_code, rec_out] = testing::RunToCompletion(
        testing::BinDir() / "epmap-sim",
        {"record", "--scenario", "building", "--frames", "2", "--out", rec.string()},
        work / "record.log", std::chrono::seconds(60));
    ASSERT_EQ(rec_code, 0) << rec_out;
    auto urdf = rec / "mav0" / "kinematics.urdf";
    if (edit_urdf) {
      const auto edited = work / "robot.urdf";
      std::ofstream(edited) << edit_urdf(ReadText(urdf));
      urdf = edited;
    }
    domain_ = domain;
    epmapd_args_ = {"--urdf", urdf.string()};
    if (durable)
      epmapd_args_.insert(epmapd_args_.end(), {"--state-dir", (work / "state").string()});
    epmapd_ = std::make_unique<testing::Epmapd>(domain, epmapd_args_, work);
    ASSERT_TRUE(epmapd_->WaitReady()) << epmapd_->process().Output();
    pub_ = std::make_unique<MobileBasePublisher>(domain);
    ASSERT_TRUE(pub_->WaitMatched());
  }
  // Stops epmapd cleanly (SIGTERM, exit 0), or kills it (`crash`: SIGKILL, nothing flushed),
  // and starts it again with the same arguments; the log of the run before is kept as
  // `log_name`.
  void Restart(const std::string& log_name, bool crash = false) {
    epmapd_->process().Signal(crash ? SIGKILL : SIGTERM);
    const auto code = epmapd_->process().Wait(std::chrono::seconds(20));
    ASSERT_TRUE(code.has_value()) << "epmapd did not stop";
    if (!crash) {
      EXPECT_EQ(*code, 0) << epmapd_->process().Output();
    }
    epmapd_.reset();
    std::filesystem::rename(work_ / "epmapd.log", work_ / log_name);
    epmapd_ = std::make_unique<testing::Epmapd>(domain_, epmapd_args_, work_);
    ASSERT_TRUE(epmapd_->WaitReady()) << epmapd_->process().Output();
    ASSERT_TRUE(pub_->WaitMatched());
  }
  // The status once the maps have taken at least n key frames (or after 30 s).
  v1::ServiceStatus WaitForKeyFrames(uint64_t n) {
    return epmapd_->WaitStatus(
        [n](const v1::ServiceStatus& s) {
          return testing::Epmapd::Count(s.events(), "maps_key_frames") >= n;
        },
        std::chrono::seconds(30));
  }
  // Frame i's stamp: 5 frames a second.
  static int64_t Stamp(int i) { return 1'700'000'000'000'000'000 + i * 200'000'000LL; }
  // The service stops first (it writes into the folder); the folder stays when a check failed.
  void TearDown() override {
    pub_.reset();
    epmapd_.reset();
    if (!work_.empty() && !HasFailure()) std::filesystem::remove_all(work_);
  }

  std::filesystem::path work_;
  uint32_t domain_ = 0;
  std::vector<std::string> epmapd_args_;
  std::unique_ptr<testing::Epmapd> epmapd_;
  std::unique_ptr<MobileBasePublisher> pub_;
};

// Odometry jumping or going back in time, a pan outside the URDF's limits and a key frame
// without edges: each counted under its reason, the maps keep every good key frame.
TEST_F(MapsFromPublishedFrames, BadInputIsCountedAndTheMapsStayIntact) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-bad-input", 62));
  auto& epmapd = *epmapd_;
  auto& pub = *pub_;
  const auto stamp = &Stamp;
  int good = 0;
  for (int i = 0; i < 6; ++i, ++good) pub.Frame(stamp(i), 0.3 * i, 0.0, false);
  pub.Frame(stamp(6), 0.3 * 6 + 5.0, 0.0, false);  // odometry jumps 5 m for one sample
  pub.Frame(stamp(7), 0.3 * 7, 3.0, false);        // pan beyond its 2.6 rad limit
  pub.Odometry(stamp(7) - 50'000'000, 0.3 * 7);    // odometry back in time
  pub.Frame(stamp(8), 0.3 * 8, 0.0, true);         // nothing to see: no edges
  ++good;
  pub.Frame(stamp(9), 0.3 * 9, 0.0, false);
  ++good;

  const auto status = epmapd.WaitStatus(
      [&](const v1::ServiceStatus& s) {
        return testing::Epmapd::Count(s.events(), "maps_key_frames") +
                   testing::Epmapd::Count(s.key_frames_refused_by_reason(), "maps:odometry_jump") +
                   testing::Epmapd::Count(s.key_frames_refused_by_reason(),
                                          "maps:joint_out_of_range") >=
               static_cast<uint64_t>(good + 2);
      },
      std::chrono::seconds(30));
  const auto count = [&](const auto& counters, const char* reason) {
    return testing::Epmapd::Count(counters, reason);
  };
  EXPECT_EQ(status.mode(), "mobile-base");
  EXPECT_EQ(count(status.key_frames_refused_by_reason(), "maps:odometry_jump"), 1u)
      << status.DebugString();
  EXPECT_EQ(count(status.key_frames_refused_by_reason(), "maps:joint_out_of_range"), 1u)
      << status.DebugString();
  EXPECT_GE(status.key_frames_refused(), 2u) << status.DebugString();
  // The frames themselves were processed: a refused key frame is not a rejected frame.
  for (const auto& c : status.rejected_by_reason()) {
    EXPECT_NE(c.reason().rfind("maps:", 0), 0u) << c.reason() << " " << c.count();
  }
  EXPECT_GE(count(status.rejected_by_reason(), "odometry:stamp_not_increasing"), 1u)
      << status.DebugString();
  EXPECT_EQ(count(status.events(), "maps_key_frame_without_edges"), 1u) << status.DebugString();
  // The odometry's and the images' frames are those the service expects: no frame warning.
  for (const auto& e : status.events()) {
    EXPECT_EQ(e.reason().find("_not_"), std::string::npos) << e.reason();
  }
  EXPECT_EQ(count(status.events(), "maps_key_frames"), static_cast<uint64_t>(good))
      << status.DebugString();

  // The maps answer with every good key frame and the newest pose.
  grpc::ClientContext context;
  v1::PoseEstimate pose;
  ASSERT_TRUE(epmapd.stub().GetPose(&context, {}, &pose).ok());
  EXPECT_EQ(pose.keyframes(), static_cast<uint32_t>(good));
  EXPECT_NEAR(pose.odometry().x(), 0.3 * 9, 1e-6);
  EXPECT_TRUE(std::isfinite(pose.corrected().x()) && std::isfinite(pose.corrected().theta()));
  EXPECT_LT(std::abs(pose.difference().theta()), 0.05);
  // The newest disparity's camera pose is the chain's (base -> cam0, near the base whatever the
  // odometry says), with the base's odometry pose beside it.
  grpc::ClientContext disparity_context;
  v1::GetDisparityRequest newest;
  newest.set_newer_than_ns(stamp(9) - 1);  // the last frame's, however the status raced it
  newest.set_wait_ms(5000);
  v1::DisparityMap disparity;
  ASSERT_TRUE(epmapd.stub().GetDisparity(&disparity_context, newest, &disparity).ok());
  EXPECT_EQ(disparity.stamp_ns(), stamp(9));
  // The frames are the URDF's: its root link and the left camera's optical link.
  EXPECT_EQ(disparity.camera_pose().parent_frame(), "base_link");
  EXPECT_EQ(disparity.camera_pose().child_frame(), "cam0_optical");
  EXPECT_LT(disparity.camera_pose().translation().x(), 0.5)
      << disparity.camera_pose().DebugString();
  ASSERT_TRUE(disparity.has_base_pose());
  EXPECT_EQ(disparity.base_pose().parent_frame(), "odom");
  EXPECT_EQ(disparity.base_pose().child_frame(), "base_link");
  EXPECT_NEAR(disparity.base_pose().translation().x(), 0.3 * 9, 1e-6);
  grpc::ClientContext grid_context;
  v1::GetOccupancyGridRequest request;
  request.set_layer(3);  // the default grid has 3 height bands
  v1::OccupancyGrid grid;
  const auto bad_layer = epmapd.stub().GetOccupancyGrid(&grid_context, request, &grid);
  EXPECT_EQ(bad_layer.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(bad_layer.error_message().find("layers 0..2"), std::string::npos)
      << bad_layer.error_message();
  // A height with no band below it, not a number, or given with a layer: INVALID_ARGUMENT.
  for (const double max_height_m : {0.05, -1.0, std::numeric_limits<double>::quiet_NaN()}) {
    grpc::ClientContext context;
    v1::GetOccupancyGridRequest below;
    below.set_max_height_m(max_height_m);
    const auto status = epmapd.stub().GetOccupancyGrid(&context, below, &grid);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << max_height_m;
    EXPECT_NE(status.error_message().find("lowest band's floor, 0.1 m"), std::string::npos)
        << status.error_message();
  }
  grpc::ClientContext both_context;
  v1::GetOccupancyGridRequest both;
  both.set_layer(0);
  both.set_max_height_m(1.0);
  const auto both_status = epmapd.stub().GetOccupancyGrid(&both_context, both, &grid);
  EXPECT_EQ(both_status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(both_status.error_message().find("not both"), std::string::npos)
      << both_status.error_message();
}

// A robot that stops and looks around: while the base stands, the maps served already hold
// what it sees there (marked provisional); once the base moves on, the stop joins them for good.
TEST_F(MapsFromPublishedFrames, AStopUnderWayIsServedBeforeTheBaseMovesOn) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-open-stop", 63));
  auto& epmapd = *epmapd_;
  auto& pub = *pub_;
  const auto stamp = &Stamp;
  const auto key_frames = [this](uint64_t n) { return WaitForKeyFrames(n); };
  // Standing at x = 0, the head pans: four key frames at one stop.
  const double pans[] = {0.0, 0.3, 0.6, 0.9};
  for (int i = 0; i < 4; ++i) pub.Frame(stamp(i), 0.0, pans[i], false);
  const auto standing = key_frames(4);
  ASSERT_EQ(testing::Epmapd::Count(standing.events(), "maps_key_frames"), 4u)
      << standing.DebugString();

  // The key frame counter moves before the snapshot with that key frame is published: ask for
  // the maps of the 4th key frame (its stamp) so as not to read the 3rd's under load.
  const auto maps_of = [&](int64_t stamp_ns, v1::PerceptualMap* map) {
    grpc::ClientContext context;
    v1::GetPerceptualMapRequest request;
    request.set_newer_than_ns(stamp_ns - 1);
    request.set_wait_ms(10000);
    const auto status = epmapd.stub().GetPerceptualMap(&context, request, map);
    ASSERT_TRUE(status.ok()) << status.error_message();
  };
  v1::PerceptualMap during;
  ASSERT_NO_FATAL_FAILURE(maps_of(stamp(3), &during));
  EXPECT_TRUE(during.includes_open_stop());
  EXPECT_GE(during.views_size(), 1);
  v1::OccupancyGrid grid;
  {
    grpc::ClientContext context;
    const auto status = epmapd.stub().GetOccupancyGrid(&context, {}, &grid);
    ASSERT_TRUE(status.ok()) << status.error_message();  // before: no known cell until it moved
  }
  EXPECT_TRUE(grid.includes_open_stop());
  EXPECT_GT(grid.width() * grid.height(), 0u);

  // The base moves on: the stop is closed and joins the maps for good.
  pub.Frame(stamp(4), 0.5, 0.9, false);
  key_frames(5);
  v1::PerceptualMap after;
  ASSERT_NO_FATAL_FAILURE(maps_of(stamp(4), &after));
  EXPECT_FALSE(after.includes_open_stop());
  EXPECT_EQ(after.views_size(), during.views_size());
  EXPECT_EQ(after.segments_size(), during.segments_size());
}

// The maps are durable (state dir): after a clean restart, epmapd goes on with the maps it
// had when the odometry continues; when the odometry starts over somewhere else, new maps.
TEST_F(MapsFromPublishedFrames, TheMapsSurviveARestart) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-restart", 66, {}, /*durable=*/true));
  const auto stamp = &Stamp;
  const auto perceptual_map = [this] {
    grpc::ClientContext context;
    v1::PerceptualMap map;
    EXPECT_TRUE(epmapd_->stub().GetPerceptualMap(&context, {}, &map).ok());
    return map;
  };
  const auto pose = [this] {
    grpc::ClientContext context;
    v1::PoseEstimate p;
    EXPECT_TRUE(epmapd_->stub().GetPose(&context, {}, &p).ok());
    return p;
  };
  const auto events = [this](const char* name) {
    v1::ServiceStatus status;
    EXPECT_TRUE(epmapd_->Status(&status).ok());
    return testing::Epmapd::Count(status.events(), name);
  };
  // Two panning stops (x = 0 and 0.5), then on to x = 1: both stops join the maps.
  int i = 0;
  for (const double pan : {0.0, 0.3, 0.6, 0.9}) pub_->Frame(stamp(i++), 0.0, pan, false);
  for (const double pan : {0.6, 0.3, 0.0}) pub_->Frame(stamp(i++), 0.5, pan, false);
  pub_->Frame(stamp(i++), 1.0, 0.0, false);
  ASSERT_EQ(testing::Epmapd::Count(WaitForKeyFrames(8).events(), "maps_key_frames"), 8u);
  const v1::PerceptualMap before = perceptual_map();
  const v1::PoseEstimate pose_before = pose();
  ASSERT_FALSE(before.includes_open_stop());
  ASSERT_GE(before.views_size(), 2);
  ASSERT_GT(before.segments_size(), 0);

  EXPECT_FALSE(before.resumed_unconfirmed());
  const auto same_segments = [](const v1::PerceptualMap& a, const v1::PerceptualMap& b) {
    return a.segments_size() == b.segments_size() &&
           std::equal(a.segments().begin(), a.segments().end(), b.segments().begin(),
                      [](const v1::MapSegment& x, const v1::MapSegment& y) {
                        return x.id() == y.id() && x.x1() == y.x1() && x.y1() == y.y1() &&
                               x.x2() == y.x2() && x.y2() == y.y2();
                      });
  };

  // A clean restart. Before any frame comes, a planner already gets the maps as saved, marked
  // as not yet confirmed by a key frame.
  ASSERT_NO_FATAL_FAILURE(Restart("epmapd-1.log"));
  EXPECT_TRUE(std::filesystem::exists(work_ / "state" / "maps.sqlite3"));
  EXPECT_EQ(events("maps_resumed"), 1u);
  {
    // GetStatus says what is on disk: the maps of the 8 key frames, saved at the shutdown.
    v1::ServiceStatus status;
    ASSERT_TRUE(epmapd_->Status(&status).ok());
    ASSERT_TRUE(status.has_saved_maps());
    EXPECT_TRUE(status.saved_maps().saved());
    EXPECT_EQ(status.saved_maps().key_frames(), 8u);
    EXPECT_GT(status.saved_maps().bytes(), 1000u);
    EXPECT_EQ(status.saved_maps().path(), (work_ / "state" / "maps.sqlite3").string());
  }
  const v1::PerceptualMap at_start = perceptual_map();
  EXPECT_TRUE(at_start.resumed_unconfirmed());
  EXPECT_TRUE(same_segments(at_start, before)) << at_start.DebugString();
  EXPECT_EQ(at_start.stamp_ns(), before.stamp_ns());
  EXPECT_EQ(pose().keyframes(), pose_before.keyframes());
  {
    grpc::ClientContext context;
    v1::OccupancyGrid grid;
    ASSERT_TRUE(epmapd_->stub().GetOccupancyGrid(&context, {}, &grid).ok());
    EXPECT_TRUE(grid.resumed_unconfirmed());
    EXPECT_GT(grid.width(), 0u);
    // ROS planners get it too: rt/map (latched) carries the saved grid before any frame.
    const auto latched = LatchedGridWithStamp(domain_, before.stamp_ns(), std::chrono::seconds(15));
    ASSERT_TRUE(latched.has_value()) << "no saved grid on rt/map after the restart";
    EXPECT_EQ(latched->info().width(), grid.width());
    EXPECT_EQ(latched->info().height(), grid.height());
  }
  const auto [pose_code, pose_out] = testing::RunToCompletion(
      testing::BinDir() / "epmapctl", {"--server", epmapd_->address(), "pose", "--json"},
      work_ / "ctl-pose.log", std::chrono::seconds(30));
  ASSERT_EQ(pose_code, 0) << pose_out;
  EXPECT_NE(pose_out.find("\"resumed_unconfirmed\":true"), std::string::npos) << pose_out;

  // The robot drives on in the same odometry frame: the first key frame confirms the maps.
  pub_->Frame(stamp(i++), 1.3, 0.0, false);
  WaitForKeyFrames(1);
  EXPECT_EQ(events("maps_resumed"), 1u);
  EXPECT_EQ(events("maps_resume_dropped"), 0u);
  const v1::PerceptualMap resumed = perceptual_map();
  const v1::PoseEstimate pose_resumed = pose();
  EXPECT_FALSE(resumed.resumed_unconfirmed());
  EXPECT_FALSE(pose_resumed.resumed_unconfirmed());
  EXPECT_EQ(pose_resumed.keyframes(), pose_before.keyframes() + 1);
  EXPECT_GE(resumed.views_size(), before.views_size());
  // Every segment of before is there, with its id and ends.
  ASSERT_GE(resumed.segments_size(), before.segments_size());
  for (const auto& old : before.segments()) {
    const auto same = std::find_if(
        resumed.segments().begin(), resumed.segments().end(), [&](const v1::MapSegment& s) {
          return s.id() == old.id() && s.x1() == old.x1() && s.y1() == old.y1() &&
                 s.x2() == old.x2() && s.y2() == old.y2();
        });
    EXPECT_NE(same, resumed.segments().end()) << "segment " << old.id() << " is gone";
  }
  // The correction carries over: the corrected pose is the odometry's step on from the last one.
  EXPECT_NEAR(pose_resumed.difference().theta(), pose_before.difference().theta(), 0.05);

  // Another restart, and the odometry starts over 5 m away (the base was carried, or restarted
  // its odometry): the saved maps are not this odometry's, and new maps start.
  ASSERT_NO_FATAL_FAILURE(Restart("epmapd-2.log"));
  EXPECT_TRUE(perceptual_map().resumed_unconfirmed());  // served as saved until a key frame says
  pub_->Frame(stamp(i++), 6.3, 0.0, false);
  WaitForKeyFrames(1);
  EXPECT_EQ(events("maps_resumed"), 1u);
  EXPECT_EQ(events("maps_resume_dropped"), 1u);
  EXPECT_EQ(pose().keyframes(), 1u);
  const v1::PerceptualMap fresh = perceptual_map();
  EXPECT_EQ(fresh.segments_size(), 0);
  EXPECT_FALSE(fresh.resumed_unconfirmed());
  const std::string log = ReadText(work_ / "epmapd.log");
  EXPECT_NE(log.find("not this odometry's"), std::string::npos) << log;

  // A planner resets the maps: the saved ones (still the first run's) are cleared at once, the
  // served ones at the next frame, which starts new maps; a restart then has nothing to resume.
  const auto [code, out] = testing::RunToCompletion(
      testing::BinDir() / "epmapctl", {"--server", epmapd_->address(), "reset-maps", "--json"},
      work_ / "ctl-reset.log", std::chrono::seconds(30));
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("{\"key_frames_dropped\":1,\"saved_maps_cleared\":true}"), std::string::npos)
      << out;
  {
    v1::ServiceStatus status;
    ASSERT_TRUE(epmapd_->Status(&status).ok());
    EXPECT_FALSE(status.saved_maps().saved());  // cleared at once
  }
  pub_->Frame(stamp(i++), 6.6, 0.0, false);
  WaitForKeyFrames(2);
  EXPECT_EQ(events("maps_reset"), 1u);
  EXPECT_EQ(pose().keyframes(), 1u);
  ASSERT_NO_FATAL_FAILURE(Restart("epmapd-3.log"));
  {
    grpc::ClientContext context;
    v1::PerceptualMap none;
    EXPECT_EQ(epmapd_->stub().GetPerceptualMap(&context, {}, &none).error_code(),
              grpc::StatusCode::FAILED_PRECONDITION);
  }
  pub_->Frame(stamp(i++), 6.9, 0.0, false);
  WaitForKeyFrames(1);
  EXPECT_EQ(events("maps_resumed"), 0u);
  EXPECT_EQ(events("maps_resume_dropped"), 0u);
  EXPECT_EQ(pose().keyframes(), 1u);
}

// A crash (SIGKILL) loses only what came after the last save: the maps come back as they were
// saved when the first stop joined them (or the second, if the two merges were more than
// maps.save_period_s apart on a slow machine).
TEST_F(MapsFromPublishedFrames, TheMapsSurviveACrashAsLastSaved) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-crash", 67, {}, /*durable=*/true));
  const auto stamp = &Stamp;
  int i = 0;
  for (const double pan : {0.0, 0.3, 0.6, 0.9}) pub_->Frame(stamp(i++), 0.0, pan, false);
  for (const double pan : {0.6, 0.3, 0.0}) pub_->Frame(stamp(i++), 0.5, pan, false);
  pub_->Frame(stamp(i++), 1.0, 0.0, false);
  const auto status = WaitForKeyFrames(8);
  ASSERT_GE(testing::Epmapd::Count(status.events(), "maps_saved"), 1u) << status.DebugString();

  ASSERT_NO_FATAL_FAILURE(Restart("epmapd-1.log", /*crash=*/true));
  // The killed process's readers stay matched until their lease ends, so the publisher cannot
  // tell when the new ones are there: the robot stands at x = 1.3 and sends a frame a second
  // until the service has one (the later ones, at the same pose, are no key frames).
  v1::ServiceStatus after;
  for (int attempt = 0; attempt < 30; ++attempt) {
    pub_->Frame(stamp(i++), 1.3, 0.0, false);
    after = epmapd_->WaitStatus(
        [](const v1::ServiceStatus& s) {
          return testing::Epmapd::Count(s.events(), "maps_key_frames") >= 1;
        },
        std::chrono::seconds(1));
    if (testing::Epmapd::Count(after.events(), "maps_key_frames") >= 1) break;
  }
  EXPECT_EQ(testing::Epmapd::Count(after.events(), "maps_resumed"), 1u) << after.DebugString();
  grpc::ClientContext context;
  v1::PoseEstimate pose;
  ASSERT_TRUE(epmapd_->stub().GetPose(&context, {}, &pose).ok());
  // Saved when stop 1 joined (at key frame 5) or stop 2 (key frame 8), plus the one now.
  EXPECT_TRUE(pose.keyframes() == 6u || pose.keyframes() == 9u) << pose.DebugString();
}

// Saved maps belong to the camera they were made with: a restarted epmapd whose first frame
// comes from another camera starts new maps; and a reset before any frame stops serving the
// saved ones at once.
TEST_F(MapsFromPublishedFrames, SavedMapsOfAnotherCameraAreNotResumed) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-other-camera", 68, {}, /*durable=*/true));
  const auto stamp = &Stamp;
  const auto events = [this](const char* name) {
    v1::ServiceStatus status;
    EXPECT_TRUE(epmapd_->Status(&status).ok());
    return testing::Epmapd::Count(status.events(), name);
  };
  const auto map_status = [this](v1::PerceptualMap* map) {
    grpc::ClientContext context;
    return epmapd_->stub().GetPerceptualMap(&context, {}, map);
  };
  int i = 0;
  for (const double pan : {0.0, 0.3, 0.6}) pub_->Frame(stamp(i++), 0.0, pan, false);
  pub_->Frame(stamp(i++), 0.5, 0.0, false);
  WaitForKeyFrames(4);
  v1::PerceptualMap saved;
  ASSERT_TRUE(map_status(&saved).ok());

  ASSERT_NO_FATAL_FAILURE(Restart("epmapd-1.log"));
  v1::PerceptualMap map;
  ASSERT_TRUE(map_status(&map).ok());
  EXPECT_TRUE(map.resumed_unconfirmed());
  EXPECT_EQ(map.segments_size(), saved.segments_size());
  pub_->SetFocalLength(110);  // the odometry continues, but the camera is not the same
  pub_->Frame(stamp(i++), 0.8, 0.0, false);
  WaitForKeyFrames(1);
  EXPECT_EQ(events("maps_resumed"), 1u);
  EXPECT_EQ(events("maps_saved_not_resumed"), 1u);
  EXPECT_EQ(events("maps_restarted_new_rectification"), 0u);
  ASSERT_TRUE(map_status(&map).ok());
  EXPECT_FALSE(map.resumed_unconfirmed());
  EXPECT_EQ(map.segments_size(), 0);
  EXPECT_NE(ReadText(work_ / "epmapd.log").find("made with another camera"), std::string::npos);

  // The same state folder under a head (no maps): nothing is resumed or served from it.
  epmapd_args_.insert(epmapd_args_.end(), {"--mode", "head"});
  ASSERT_NO_FATAL_FAILURE(Restart("epmapd-2.log"));
  EXPECT_EQ(map_status(&map).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  {
    v1::ServiceStatus status;
    ASSERT_TRUE(epmapd_->Status(&status).ok());
    EXPECT_FALSE(status.has_saved_maps());
    EXPECT_EQ(testing::Epmapd::Count(status.events(), "maps_resumed"), 0u);
  }
  epmapd_args_.resize(epmapd_args_.size() - 2);

  // The new maps made no stop, so the store still holds the first ones: a restart serves them
  // again, until a reset, which stops serving them at once, before any frame.
  ASSERT_NO_FATAL_FAILURE(Restart("epmapd-3.log"));
  ASSERT_TRUE(map_status(&map).ok());
  EXPECT_TRUE(map.resumed_unconfirmed());
  grpc::ClientContext context;
  v1::ResetMapsResponse reset;
  ASSERT_TRUE(epmapd_->stub().ResetMaps(&context, {}, &reset).ok());
  EXPECT_TRUE(reset.saved_maps_cleared());
  EXPECT_EQ(reset.key_frames_dropped(), 4u);
  EXPECT_EQ(map_status(&map).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

// A local planner polls a window of the grid around the robot instead of the whole floor: the
// cells are the whole map's, on its lattice, unknown beyond what the map has seen; a window that
// is no box, or larger than a message may be, is refused by name and the service goes on.
TEST_F(MapsFromPublishedFrames, ALocalPlannerGetsAWindowOfTheGrid) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-window", 69));
  for (int i = 0; i < 5; ++i) pub_->Frame(Stamp(i), 0.3 * i, 0.0, false);  // a key frame each
  WaitForKeyFrames(5);
  auto& stub = epmapd_->stub();
  const auto get = [&](const v1::GetOccupancyGridRequest& request, v1::OccupancyGrid* grid) {
    grpc::ClientContext context;
    return stub.GetOccupancyGrid(&context, request, grid);
  };
  v1::GetOccupancyGridRequest whole_request;
  whole_request.set_newer_than_ns(Stamp(4) - 1);  // the fifth key frame's maps
  whole_request.set_wait_ms(10000);
  v1::OccupancyGrid whole;
  ASSERT_TRUE(get(whole_request, &whole).ok());
  ASSERT_FALSE(whole.window());
  const double res = whole.resolution_m();
  // Every cell of `window` equals the whole map's cell at the same place, or is unknown (255,
  // confidence 0) where the whole map has none; returns how many lie in the whole map.
  const auto check_cells = [&](const v1::OccupancyGrid& window) {
    EXPECT_TRUE(window.window());
    EXPECT_EQ(window.stamp_ns(), whole.stamp_ns());
    EXPECT_EQ(window.occupancy().size(), static_cast<size_t>(window.width()) * window.height());
    EXPECT_EQ(window.confidence().size(), window.occupancy().size());
    const long dc = std::lround((window.origin().x() - whole.origin().x()) / res);
    const long dr = std::lround((window.origin().y() - whole.origin().y()) / res);
    int inside = 0, mismatched = 0;
    for (long r = 0; r < static_cast<long>(window.height()); ++r) {
      for (long c = 0; c < static_cast<long>(window.width()); ++c) {
        const size_t i = static_cast<size_t>(r * window.width() + c);
        const long wc = c + dc, wr = r + dr;
        uint8_t occupancy = 255, confidence = 0;
        if (wc >= 0 && wr >= 0 && wc < static_cast<long>(whole.width()) &&
            wr < static_cast<long>(whole.height())) {
          const size_t j = static_cast<size_t>(wr * whole.width() + wc);
          occupancy = static_cast<uint8_t>(whole.occupancy()[j]);
          confidence = static_cast<uint8_t>(whole.confidence()[j]);
          ++inside;
        }
        mismatched += static_cast<uint8_t>(window.occupancy()[i]) != occupancy ||
                      static_cast<uint8_t>(window.confidence()[i]) != confidence;
      }
    }
    EXPECT_EQ(mismatched, 0);
    return inside;
  };

  // A box in the world frame: 3 m x 2 m from (-0.5, -1.0), 30 x 20 cells of 0.1 m.
  v1::GetOccupancyGridRequest box;
  box.mutable_region()->set_min_x(-0.5);
  box.mutable_region()->set_min_y(-1.0);
  box.mutable_region()->set_max_x(2.5);
  box.mutable_region()->set_max_y(1.0);
  v1::OccupancyGrid window;
  ASSERT_TRUE(get(box, &window).ok());
  EXPECT_NEAR(window.origin().x(), -0.5, 1e-9);
  EXPECT_NEAR(window.origin().y(), -1.0, 1e-9);
  EXPECT_EQ(window.width(), 30u);
  EXPECT_EQ(window.height(), 20u);
  EXPECT_GT(check_cells(window), 0);
  EXPECT_TRUE(std::any_of(window.occupancy().begin(), window.occupancy().end(), [](char v) {
    return static_cast<uint8_t>(v) != 255;
  })) << "the robot drove through this box: it has known cells";
  // Far from anything the robot saw: the size asked for, all unknown.
  v1::GetOccupancyGridRequest far = box;
  far.mutable_region()->set_min_x(500);
  far.mutable_region()->set_max_x(501);
  ASSERT_TRUE(get(far, &window).ok());
  EXPECT_EQ(window.width(), 10u);
  EXPECT_EQ(check_cells(window), 0);
  EXPECT_TRUE(std::all_of(window.occupancy().begin(), window.occupancy().end(),
                          [](char v) { return static_cast<uint8_t>(v) == 255; }));

  // A square around the robot (its corrected pose at the same key frame), and one band only.
  v1::PoseEstimate pose;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub.GetPose(&context, {}, &pose).ok());
  }
  v1::GetOccupancyGridRequest around;
  around.set_around_robot_m(4.0);
  around.set_layer(1);
  ASSERT_TRUE(get(around, &window).ok());
  EXPECT_FALSE(window.combined());
  EXPECT_EQ(window.layer(), 1u);
  EXPECT_NEAR(window.origin().x(), std::floor((pose.corrected().x() - 2.0) / res) * res, 1e-9);
  EXPECT_NEAR(window.origin().y(), std::floor((pose.corrected().y() - 2.0) / res) * res, 1e-9);
  EXPECT_GE(window.width(), 40u);
  EXPECT_LE(window.width(), 41u);
  {
    v1::GetOccupancyGridRequest layer1 = whole_request;
    layer1.set_layer(1);
    ASSERT_TRUE(get(layer1, &whole).ok());  // compared with band 1 of the whole map
    EXPECT_GT(check_cells(window), 0);
  }

  // epmapctl writes the window for map_server, its origin in the YAML.
  const auto pgm = work_ / "window.pgm";
  const auto [code, out] =
      Ctl(*epmapd_, work_, {"grid", "--out", pgm.string(), "--region", "-0.5,-1,2.5,1"});
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("30x20 cells of 0.100 m (the window asked for)"), std::string::npos) << out;
  EXPECT_NE(ReadText(work_ / "window.yaml").find("origin: [-0.500000, -1.000000, 0.0]"),
            std::string::npos);
  const auto [bad_code, bad_out] =
      Ctl(*epmapd_, work_, {"grid", "--out", pgm.string(), "--region", "0,0,1"});
  EXPECT_NE(bad_code, 0) << bad_out;

  // Bad windows: INVALID_ARGUMENT, saying what is wrong.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto refused = [&](const v1::GetOccupancyGridRequest& request, const std::string& says) {
    v1::OccupancyGrid unused;
    const auto status = get(request, &unused);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << request.DebugString();
    EXPECT_NE(status.error_message().find(says), std::string::npos) << status.error_message();
  };
  v1::GetOccupancyGridRequest inverted = box;
  inverted.mutable_region()->set_max_x(-2.0);
  refused(inverted, "min_x < max_x");
  v1::GetOccupancyGridRequest not_a_number = box;
  not_a_number.mutable_region()->set_min_y(nan);
  refused(not_a_number, "must be finite");
  v1::GetOccupancyGridRequest both = box;
  both.set_around_robot_m(3.0);
  refused(both, "not both");
  for (const double side : {0.0, -1.0, nan}) {
    v1::GetOccupancyGridRequest bad_side;
    bad_side.set_around_robot_m(side);
    refused(bad_side, "positive number of metres");
  }
  v1::GetOccupancyGridRequest huge;  // 1 km square at 0.1 m: 10^8 cells, over 64 MB
  huge.set_around_robot_m(1000.0);
  refused(huge, "api.max_message_mb 64 allows");
  v1::GetOccupancyGridRequest absurd = box;  // more cells along x than an index can hold
  absurd.mutable_region()->set_max_x(1e300);
  refused(absurd, "cells along an axis");

  // The service goes on: the whole map as before.
  v1::OccupancyGrid again;
  ASSERT_TRUE(get({}, &again).ok());
  EXPECT_FALSE(again.window());
  EXPECT_GT(again.width(), 0u);
}

// The same windows of the perceptual map: the segments with some part in the box, of the
// same key frame's map; views, path and boundaries whole.
TEST_F(MapsFromPublishedFrames, ALocalPlannerGetsTheSegmentsInAWindow) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-pmap-window", 71));
  for (int i = 0; i < 5; ++i) pub_->Frame(Stamp(i), 0.3 * i, 0.0, false);  // a key frame each
  WaitForKeyFrames(5);
  auto& stub = epmapd_->stub();
  const auto get = [&](v1::GetPerceptualMapRequest request, v1::PerceptualMap* map) {
    request.set_newer_than_ns(Stamp(4) - 1);  // the fifth key frame's maps
    request.set_wait_ms(10000);
    grpc::ClientContext context;
    return stub.GetPerceptualMap(&context, request, map);
  };
  v1::PerceptualMap whole;
  ASSERT_TRUE(get({}, &whole).ok());
  ASSERT_FALSE(whole.window());
  ASSERT_GT(whole.segments_size(), 1);
  // The ids of the whole map's segments with some part in the box, in the map's order.
  const auto ids_in = [&](const Eigen::AlignedBox2d& box) {
    std::vector<uint32_t> ids;
    for (const auto& g : whole.segments()) {
      if (perceptual_map::SegmentTouchesBox({g.x1(), g.y1()}, {g.x2(), g.y2()}, box)) {
        ids.push_back(g.id());
      }
    }
    return ids;
  };
  const auto ids_of = [](const v1::PerceptualMap& map) {
    std::vector<uint32_t> ids;
    for (const auto& g : map.segments()) ids.push_back(g.id());
    return ids;
  };
  const auto check_window = [&](const v1::PerceptualMap& window) {
    EXPECT_TRUE(window.window());
    EXPECT_EQ(window.stamp_ns(), whole.stamp_ns());
    EXPECT_EQ(window.segments_in_map(), whole.segments_in_map());
    EXPECT_EQ(window.path_size(), whole.path_size());
    EXPECT_EQ(window.views_size(), whole.views_size());
    EXPECT_EQ(window.boundary_size(), whole.boundary_size());
  };

  // A box around the first segment's first end: it, and whatever else reaches into the box.
  const auto& first = whole.segments(0);
  v1::GetPerceptualMapRequest box;
  box.mutable_region()->set_min_x(first.x1() - 0.05);
  box.mutable_region()->set_min_y(first.y1() - 0.05);
  box.mutable_region()->set_max_x(first.x1() + 0.05);
  box.mutable_region()->set_max_y(first.y1() + 0.05);
  const Eigen::AlignedBox2d box_m(Eigen::Vector2d(first.x1() - 0.05, first.y1() - 0.05),
                                  Eigen::Vector2d(first.x1() + 0.05, first.y1() + 0.05));
  v1::PerceptualMap window;
  ASSERT_TRUE(get(box, &window).ok());
  check_window(window);
  EXPECT_EQ(ids_of(window), ids_in(box_m));
  EXPECT_GE(window.segments_size(), 1);
  EXPECT_LT(window.segments_size(), whole.segments_size()) << "a 10 cm box holds a few walls";
  // Far from anything: none, and the map says how many it holds.
  v1::GetPerceptualMapRequest far;
  far.mutable_region()->set_min_x(500);
  far.mutable_region()->set_min_y(500);
  far.mutable_region()->set_max_x(501);
  far.mutable_region()->set_max_y(501);
  ASSERT_TRUE(get(far, &window).ok());
  check_window(window);
  EXPECT_EQ(window.segments_size(), 0);
  // A square around the robot, with the redundancy removal's choice on top.
  v1::PoseEstimate pose;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub.GetPose(&context, {}, &pose).ok());
  }
  v1::GetPerceptualMapRequest around;
  around.set_around_robot_m(3.0);
  ASSERT_TRUE(get(around, &window).ok());
  check_window(window);
  const Eigen::Vector2d at(pose.corrected().x(), pose.corrected().y());
  EXPECT_EQ(ids_of(window), ids_in(Eigen::AlignedBox2d(at - Eigen::Vector2d(1.5, 1.5),
                                                       at + Eigen::Vector2d(1.5, 1.5))));
  around.set_kept_only(true);
  ASSERT_TRUE(get(around, &window).ok());
  for (const auto& g : window.segments()) EXPECT_TRUE(g.kept()) << g.id();

  // epmapctl writes the window's segments and says so.
  const auto json = work_ / "window.json";
  const auto [code, out] =
      Ctl(*epmapd_, work_, {"pmap", "--out", json.string(), "--region", "500,500,501,501"});
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("wrote " + json.string() + ": 0 segments of " +
                     std::to_string(whole.segments_in_map()) + " (those in the window)"),
            std::string::npos)
      << out;
  EXPECT_NE(ReadText(json).find("\"window\":true,\"segments\":[]"), std::string::npos);

  // Bad windows: INVALID_ARGUMENT saying what is wrong, as for the grid.
  const auto refused = [&](const v1::GetPerceptualMapRequest& request, const std::string& says) {
    v1::PerceptualMap unused;
    const auto status = get(request, &unused);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << request.DebugString();
    EXPECT_NE(status.error_message().find(says), std::string::npos) << status.error_message();
  };
  v1::GetPerceptualMapRequest inverted = box;
  inverted.mutable_region()->set_max_x(first.x1() - 1.0);
  refused(inverted, "min_x < max_x");
  v1::GetPerceptualMapRequest not_a_number = box;
  not_a_number.mutable_region()->set_max_y(std::numeric_limits<double>::quiet_NaN());
  refused(not_a_number, "must be finite");
  v1::GetPerceptualMapRequest both = box;
  both.set_around_robot_m(3.0);
  refused(both, "not both");
  v1::GetPerceptualMapRequest no_side;
  no_side.set_around_robot_m(-2.0);
  refused(no_side, "positive number of metres");
  // And the whole map as before.
  ASSERT_TRUE(get({}, &window).ok());
  EXPECT_FALSE(window.window());
  EXPECT_EQ(ids_of(window), ids_of(whole));
}

// A planner that has the maps waits for the next ones instead of polling: the call returns when
// a key frame brings newer maps, DEADLINE_EXCEEDED when none comes in time.
TEST_F(MapsFromPublishedFrames, APlannerWaitsForTheNextKeyFramesMaps) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-wait", 64));
  auto& epmapd = *epmapd_;
  auto& pub = *pub_;
  const auto stamp = &Stamp;
  for (int i = 0; i < 3; ++i) pub.Frame(stamp(i), 0.3 * i, 0.0, false);  // a key frame each
  WaitForKeyFrames(3);
  const auto get_pose = [&](int64_t newer_than_ns, uint32_t wait_ms, v1::PoseEstimate* pose) {
    grpc::ClientContext context;
    v1::GetPoseRequest request;
    request.set_newer_than_ns(newer_than_ns);
    request.set_wait_ms(wait_ms);
    return epmapd.stub().GetPose(&context, request, pose);
  };
  v1::PoseEstimate have;
  ASSERT_TRUE(get_pose(0, 0, &have).ok());
  EXPECT_EQ(have.stamp_ns(), stamp(2));

  // Bad waits.
  v1::PoseEstimate unused;
  EXPECT_EQ(get_pose(-1, 0, &unused).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(get_pose(0, 40000, &unused).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  // Nothing new comes: DEADLINE_EXCEEDED after the wait, for the grid and the perceptual map too.
  const auto t0 = std::chrono::steady_clock::now();
  const auto none = get_pose(have.stamp_ns(), 300, &unused);
  const double waited_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(none.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << none.error_message();
  EXPECT_GE(waited_s, 0.25);
  {
    grpc::ClientContext context;
    v1::GetPerceptualMapRequest request;
    request.set_newer_than_ns(have.stamp_ns());
    v1::PerceptualMap map;
    EXPECT_EQ(epmapd.stub().GetPerceptualMap(&context, request, &map).error_code(),
              grpc::StatusCode::DEADLINE_EXCEEDED);
  }
  const auto [ctl_code, ctl_out] =
      testing::RunToCompletion(testing::BinDir() / "epmapctl",
                               {"--server", epmapd.address(), "pose", "--json", "--newer-than",
                                std::to_string(have.stamp_ns()), "--wait-ms", "200"},
                               work_ / "ctl-wait.log", std::chrono::seconds(30));
  EXPECT_NE(ctl_code, 0);
  EXPECT_NE(ctl_out.find("DEADLINE_EXCEEDED"), std::string::npos) << ctl_out;

  // Waiting while the robot moves on: the call returns with the next key frame's maps.
  auto next = std::async(std::launch::async, [&] {
    v1::PoseEstimate pose;
    const auto start = std::chrono::steady_clock::now();
    const auto status = get_pose(have.stamp_ns(), 20000, &pose);
    return std::make_tuple(
        status, pose,
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  pub.Frame(stamp(3), 0.9, 0.0, false);
  const auto [status, pose, took_s] = next.get();
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(pose.stamp_ns(), stamp(3));
  EXPECT_EQ(pose.keyframes(), have.keyframes() + 1);
  EXPECT_GE(took_s, 0.4) << "it returned before the key frame was published";
  std::printf("waited %.2f s for the next key frame's maps (stamp %lld)\n", took_s,
              static_cast<long long>(pose.stamp_ns()));
}

// Odometry in frames the robot's tf tree does not share with the service (another odometry
// frame than maps.odom_frame, another moving frame than the URDF's root): said once each in
// the status, and the maps go on.
TEST_F(MapsFromPublishedFrames, OdometryInOtherFramesIsSaidOnce) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-odom-frames", 65));
  pub_->SetOdometryFrames("wheel_odom", "base_footprint");
  for (int i = 0; i < 4; ++i) pub_->Frame(Stamp(i), 0.3 * i, 0.0, false);
  const auto status = WaitForKeyFrames(4);
  EXPECT_EQ(testing::Epmapd::Count(status.events(), "maps_key_frames"), 4u) << status.DebugString();
  EXPECT_EQ(testing::Epmapd::Count(status.events(), "odometry_frame_not_odom_frame:wheel_odom"), 1u)
      << status.DebugString();
  EXPECT_EQ(testing::Epmapd::Count(status.events(), "odometry_child_not_urdf_root:base_footprint"),
            1u)
      << status.DebugString();
}

// A robot whose URDF is rooted at base_footprint, with base_link 0.25 m ahead of it, and whose
// rt/odom moves base_link (as many ROS 2 bases do): the maps take the root's pose composed
// through the URDF, said once at info level, and the served odometry pose is the root's.
TEST_F(MapsFromPublishedFrames, OdometryOfALinkBelowTheUrdfRootIsComposedThroughIt) {
  ASSERT_NO_FATAL_FAILURE(Start("maps-odom-child", 66, [](std::string urdf) {
    const std::string root = "<link name=\"base_link\"/>";
    const size_t at = urdf.find(root);
    EXPECT_NE(at, std::string::npos);
    urdf.insert(at, R"(<link name="base_footprint"/>
  <joint name="base_footprint_joint" type="fixed">
    <parent link="base_footprint"/><child link="base_link"/>
    <origin xyz="0.25 0 0" rpy="0 0 0"/>
  </joint>
  )");
    return urdf;
  }));
  pub_->SetOdometryFrames("odom", "base_link");
  for (int i = 0; i < 4; ++i) pub_->Frame(Stamp(i), 0.3 * i, 0.0, false);
  const auto status = WaitForKeyFrames(4);
  EXPECT_EQ(testing::Epmapd::Count(status.events(), "maps_key_frames"), 4u) << status.DebugString();
  EXPECT_EQ(testing::Epmapd::Count(status.events(), "odometry_child_composed:base_link"), 1u)
      << status.DebugString();
  EXPECT_EQ(testing::Epmapd::Count(status.events(), "odometry_child_not_urdf_root:base_link"), 0u)
      << status.DebugString();
  // The last reading put base_link at x = 0.9 m: the root is 0.25 m behind it.
  const auto [code, out] = Ctl(*epmapd_, work_, {"pose", "--json"});
  ASSERT_EQ(code, 0) << out;
  const YAML::Node pose = YAML::Load(out);
  EXPECT_NEAR(pose["odometry"]["x"].as<double>(), 0.9 - 0.25, 1e-6) << out;
  EXPECT_NEAR(pose["odometry"]["y"].as<double>(), 0.0, 1e-6) << out;
  EXPECT_NEAR(pose["odometry"]["theta"].as<double>(), 0.0, 1e-6) << out;
}

}  // namespace
}  // namespace epmap
