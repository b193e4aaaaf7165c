#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <string>
#include <string_view>
#include <thread>

#include "perception/localisation/pose_corrector.h"
#include "perception/mobile_mapping/key_frame_selector.h"
#include "perception/mobile_mapping/map_evaluation.h"
#include "perception/mobile_mapping/mobile_mapper.h"
#include "tests/support/planar_world.h"

namespace epmap {
namespace {

using localisation::HeadingOf;
using localisation::MakePose;
using mobile_mapping::KeyFrame;
using mobile_mapping::MobileMapper;

constexpr double kDeg = std::numbers::pi / 180.0;

// A short run in the test room, rendered once for all tests: 1 m east, a quarter turn, 2 m
// north, stopping to pan (short pans, to keep the test fast); odometry over-counts turns by 4%.
class MobileMapperTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    testing::RunParams rp;
    rp.pan_stops = {0.0, 0.5, 0.0, -0.5, 0.0};
    rp.pan_rate = 2.5;
    const auto run = testing::SimulateRun({{1.0, 1.0}, {2.0, 1.0}, {2.0, 3.0}}, 0.0, rp);
    const testing::PlanarWorld world(testing::RoomWalls());
    const auto cam = testing::BumblebeeLikeCamera();
    mobile_mapping::KeyFrameSelector selector;
    frames_ = new std::vector<KeyFrame>;
    truth_ = new std::vector<Eigen::Vector3d>;
    for (size_t i = 0; i < run.size(); ++i) {
      const auto& r = run[i];
      const Eigen::Isometry2d odo = MakePose(r.odometry.x(), r.odometry.y(), r.odometry.z());
      const Eigen::Isometry3d T_base_cam = testing::CameraOnBase(r.pan);
      if (!selector.Consider(odo, T_base_cam)) continue;
      const Eigen::Isometry3d T_world_cam = testing::BaseInWorld(r.truth) * T_base_cam;
      Eigen::Isometry3d T_world_right = T_world_cam;
      T_world_right.translation() += T_world_cam.linear().col(0) * cam.baseline_m;
      KeyFrame f;
      f.stamp_ns = r.stamp_ns;
      f.left = world.Render(T_world_cam, cam, static_cast<uint32_t>(2 * i));
      f.right = world.Render(T_world_right, cam, static_cast<uint32_t>(2 * i + 1));
      f.T_odom_base = odo;
      f.T_base_cam = T_base_cam;
      f.joint_positions = {r.pan};
      frames_->push_back(f);
      truth_->push_back(r.truth);
    }
  }
  static void TearDownTestSuite() {
    delete frames_;
    delete truth_;
  }

  static mobile_mapping::MobileMapperParams Params() {
    mobile_mapping::MobileMapperParams p;
    p.view_min_key_frames = 2;  // this run pans at its stops
    p.joint_limits = {{"pan", -1.7, 1.7}};
    return p;
  }

  // Truth in the odometry/world frame (the robot's start pose).
  static Eigen::Vector3d TruthInStart(size_t k) {
    const auto& t0 = truth_->front();
    const Eigen::Isometry2d T = MakePose(t0.x(), t0.y(), t0.z()).inverse() *
                                MakePose((*truth_)[k].x(), (*truth_)[k].y(), (*truth_)[k].z());
    return {T.translation().x(), T.translation().y(), HeadingOf(T)};
  }

  static std::vector<KeyFrame>* frames_;
  static std::vector<Eigen::Vector3d>* truth_;
};

std::vector<KeyFrame>* MobileMapperTest::frames_ = nullptr;
std::vector<Eigen::Vector3d>* MobileMapperTest::truth_ = nullptr;

TEST_F(MobileMapperTest, BuildsBothMapsAndCorrectsTheHeading) {
  MobileMapper mapper(testing::BumblebeeLikeCamera(), Params());
  for (const auto& f : *frames_) {
    const auto report = mapper.AddKeyFrame(f);
    ASSERT_TRUE(report.accepted) << report.rejection->message;
  }
  mapper.Flush();
  const auto snap = mapper.Snapshot();
  ASSERT_EQ(snap->poses.size(), frames_->size());
  EXPECT_GE(snap->counters.views, 3u);
  EXPECT_GT(snap->counters.visual_heading, 5u);
  const auto last = TruthInStart(frames_->size() - 1);
  const double odo_error = std::abs(
      localisation::WrapAngle(HeadingOf(snap->poses.back().T_world_base_odometry) - last.z()));
  const double cor_error =
      std::abs(localisation::WrapAngle(HeadingOf(snap->poses.back().T_world_base) - last.z()));
  EXPECT_GT(odo_error, 3 * kDeg);  // 4% of a quarter turn
  EXPECT_LT(cor_error, 1 * kDeg);

  // Both maps, in the start frame, lie on the room's walls.
  const auto& t0 = truth_->front();
  const Eigen::Isometry2d T_start_world = MakePose(t0.x(), t0.y(), t0.z()).inverse();
  std::vector<mobile_mapping::Segment2> walls;
  for (const auto& w : testing::RoomWalls())
    walls.push_back({T_start_world * w.a, T_start_world * w.b});
  std::vector<mobile_mapping::Segment2> segments;
  for (const auto& s : snap->perceptual().segments) segments.push_back({s.a, s.b});
  ASSERT_GT(segments.size(), 20u);
  EXPECT_GT(mobile_mapping::CoveredShare(segments, walls, 0.3), 0.9);  // map on the walls
  const auto grid = snap->grid.Export();
  EXPECT_GT(mobile_mapping::ScoreGrid(grid, walls).intersection, 50u);
  EXPECT_GE(snap->perceptual().path.size(), 3u);
}

// Beyond paper 002: the heading registered against the global map. With the visual heading
// off, the heading is the odometry's, 4 % over-counted in the quarter turn (3.6 degrees); the
// stops after the turn see the walls already mapped turned by it, and turning the local map
// back brings it onto them. (The corrections' sizes need the filter to expect this
// odometry's turn error, heading_drift_per_rad.)
TEST_F(MobileMapperTest, TheMapRegistrationCorrectsAHeadingThatDrifted) {
  const auto final_heading_error = [&](double step_rad, uint64_t* turns) {
    auto p = Params();
    p.visual_heading = false;
    p.correlation_heading_step_rad = step_rad;
    p.heading_drift_per_rad = 0.05;  // this odometry's turns err by 4 %
    MobileMapper mapper(testing::BumblebeeLikeCamera(), p);
    for (const auto& f : *frames_) EXPECT_TRUE(mapper.AddKeyFrame(f).accepted);
    mapper.Flush();
    *turns = mapper.counters().heading_turns;
    const auto last = TruthInStart(frames_->size() - 1);
    return std::abs(
        localisation::WrapAngle(HeadingOf(mapper.poses().latest().T_world_base) - last.z()));
  };
  uint64_t turns_off = 0, turns_on = 0;
  const double off = final_heading_error(0.0, &turns_off);
  const double on = final_heading_error(2 * kDeg, &turns_on);
  EXPECT_EQ(turns_off, 0u);
  EXPECT_GT(turns_on, 0u);
  EXPECT_GT(off, 3 * kDeg);
  // Two stops follow the turn, each measuring at most a step: 4.1 -> 2.7 degrees.
  EXPECT_LT(on, off - 1 * kDeg) << "off " << off / kDeg << " deg, on " << on / kDeg << " deg";
}

// The corner features tracked for the heading are points of the grid too; without them the
// grid knows only what the edge points saw.
TEST_F(MobileMapperTest, TheCornerFeaturesAreGridEvidence) {
  const auto known_cells = [](bool features) {
    auto p = Params();
    p.occupancy_feature_points = features;
    MobileMapper mapper(testing::BumblebeeLikeCamera(), p);
    // The first third of the run (its first stops) is enough, and keeps the test fast.
    for (size_t k = 0; k < frames_->size() / 3; ++k) mapper.AddKeyFrame((*frames_)[k]);
    mapper.Flush();
    const auto grid = mapper.Snapshot()->grid.Export();
    return std::count_if(grid.occupancy.begin(), grid.occupancy.end(),
                         [](uint8_t v) { return v != occupancy::GridExport::kUnknown; });
  };
  const auto with = known_cells(true), without = known_cells(false);
  EXPECT_GT(without, 0);
  EXPECT_GT(with, without);
}

// view_min_key_frames = 0 (the service's setting): this run pans at its stops, so once it has
// been seen panning the moving key frames make no views (with 1 every group would be a view).
TEST_F(MobileMapperTest, AutomaticViewSizeFollowsPanningStops) {
  auto p = Params();
  p.view_min_key_frames = 0;
  MobileMapper mapper(testing::BumblebeeLikeCamera(), p);
  for (const auto& f : *frames_) ASSERT_TRUE(mapper.AddKeyFrame(f).accepted);
  mapper.Flush();
  const auto& c = mapper.counters();
  EXPECT_GE(c.views, 3u);
  EXPECT_GT(c.groups_too_short, 0u);
  EXPECT_EQ(c.views + c.groups_too_short, c.groups);
}

// The run ends standing at a stop, panning: the maps leave that stop out until the base moves
// on, the provisional snapshot merges it on copies, and it is exactly what closing the stop
// then gives.
TEST_F(MobileMapperTest, TheOpenStopIsInTheProvisionalSnapshotOnly) {
  MobileMapper mapper(testing::BumblebeeLikeCamera(), Params());
  for (const auto& f : *frames_) ASSERT_TRUE(mapper.AddKeyFrame(f).accepted);
  ASSERT_TRUE(mapper.standing_at_stop());
  const auto committed = mapper.Snapshot();
  const auto provisional = mapper.SnapshotWithOpenStop();
  EXPECT_FALSE(committed->includes_open_stop);
  EXPECT_TRUE(provisional->includes_open_stop);
  EXPECT_EQ(provisional->perceptual().views.size(), committed->perceptual().views.size() + 1);
  EXPECT_EQ(provisional->counters.views, committed->counters.views);  // nothing counted twice
  // The mapper itself is untouched.
  EXPECT_EQ(mapper.Snapshot()->perceptual().views.size(), committed->perceptual().views.size());
  EXPECT_EQ(mapper.Snapshot()->perceptual().segments.size(),
            committed->perceptual().segments.size());

  mapper.Flush();
  EXPECT_FALSE(mapper.standing_at_stop());
  const auto closed = mapper.Snapshot();
  EXPECT_EQ(closed->perceptual().views.size(), provisional->perceptual().views.size());
  ASSERT_EQ(closed->perceptual().segments.size(), provisional->perceptual().segments.size());
  for (size_t i = 0; i < closed->perceptual().segments.size(); ++i) {
    EXPECT_EQ(closed->perceptual().segments[i].a, provisional->perceptual().segments[i].a);
    EXPECT_EQ(closed->perceptual().segments[i].b, provisional->perceptual().segments[i].b);
  }
  const auto closed_grid = closed->grid.Export();
  const auto provisional_grid = provisional->grid.Export();
  EXPECT_EQ(closed_grid.occupancy, provisional_grid.occupancy);
  EXPECT_NE(closed_grid.occupancy, committed->grid.Export().occupancy);  // the stop added cells
  EXPECT_EQ(closed->poses.back().T_world_base.matrix(),
            provisional->poses.back().T_world_base.matrix());
  // Without an open stop the two snapshots agree.
  EXPECT_FALSE(mapper.SnapshotWithOpenStop()->includes_open_stop);
}

// A snapshot's perceptual map is built when first read (its boundary costs time that grows
// with the map): read late, by several readers at once, it is still the map at the time the
// snapshot was taken, built once.
TEST_F(MobileMapperTest, SnapshotsPerceptualMapIsTheOneWhenTakenHoweverLateAndManyReadIt) {
  MobileMapper mapper(testing::BumblebeeLikeCamera(), Params());
  const size_t half = frames_->size() / 2;
  for (size_t i = 0; i < half; ++i) ASSERT_TRUE(mapper.AddKeyFrame((*frames_)[i]).accepted);
  const auto expected = mapper.perceptual().Map(true);
  ASSERT_FALSE(expected.segments.empty());
  const auto snap = mapper.Snapshot();
  for (size_t i = half; i < frames_->size(); ++i) {
    ASSERT_TRUE(mapper.AddKeyFrame((*frames_)[i]).accepted);
  }
  mapper.Flush();
  ASSERT_NE(mapper.perceptual().Map(true).segments.size(), expected.segments.size());

  std::vector<const perceptual_map::PerceptualMap*> seen(4, nullptr);
  std::vector<std::thread> readers;
  for (auto& s : seen) readers.emplace_back([&s, &snap] { s = &snap->perceptual(); });
  for (auto& t : readers) t.join();
  for (const auto* s : seen) EXPECT_EQ(s, seen.front());  // one map, built once
  const auto& read = *seen.front();
  ASSERT_EQ(read.segments.size(), expected.segments.size());
  for (size_t i = 0; i < read.segments.size(); ++i) {
    EXPECT_EQ(read.segments[i].id, expected.segments[i].id);
    EXPECT_EQ(read.segments[i].a, expected.segments[i].a);
  }
  EXPECT_EQ(read.path.size(), expected.path.size());
  EXPECT_EQ(read.boundary.inner_ids, expected.boundary.inner_ids);
  EXPECT_EQ(read.boundary.outer_ids, expected.boundary.outer_ids);
  EXPECT_EQ(read.kept_segments.size(), expected.kept_segments.size());
  const auto unset = std::make_shared<const mobile_mapping::MapsSnapshot>();
  EXPECT_TRUE(unset->perceptual().segments.empty());  // no map set: an empty one
}

// The snapshot keeps the perceptual map it handed out until the map changes: every snapshot
// must still show the map as it is now, through stops, restores and dropped maps.
void ExpectSnapshotShowsTheMapNow(const MobileMapper& mapper, const std::string& when) {
  const auto now = mapper.perceptual().Map(true);
  const auto snap = mapper.Snapshot();
  ASSERT_EQ(snap->perceptual().segments.size(), now.segments.size()) << when;
  for (size_t i = 0; i < now.segments.size(); ++i) {
    EXPECT_EQ(snap->perceptual().segments[i].id, now.segments[i].id) << when;
    EXPECT_EQ(snap->perceptual().segments[i].a, now.segments[i].a) << when;
    EXPECT_EQ(snap->perceptual().segments[i].b, now.segments[i].b) << when;
  }
  EXPECT_EQ(snap->perceptual().views.size(), now.views.size()) << when;
  EXPECT_EQ(snap->perceptual().path.size(), now.path.size()) << when;
  EXPECT_EQ(snap->perceptual().boundary.inner_ids, now.boundary.inner_ids) << when;
  EXPECT_EQ(snap->perceptual().boundary.outer_ids, now.boundary.outer_ids) << when;
  EXPECT_EQ(snap->perceptual().stamp_ns, now.stamp_ns) << when;
}

TEST_F(MobileMapperTest, EverySnapshotShowsThePerceptualMapAsItIsNow) {
  MobileMapper mapper(testing::BumblebeeLikeCamera(), Params());
  size_t views = 0, unchanged = 0;
  for (size_t i = 0; i < frames_->size(); ++i) {
    const auto before = mapper.Snapshot();
    ASSERT_TRUE(mapper.AddKeyFrame((*frames_)[i]).accepted);
    ExpectSnapshotShowsTheMapNow(mapper, "after key frame " + std::to_string(i));
    const auto after = mapper.Snapshot();
    if (after->perceptual().views.size() != before->perceptual().views.size()) ++views;
    if (after->perceptual().segments.size() == before->perceptual().segments.size()) ++unchanged;
  }
  EXPECT_GE(views, 3u);      // the map grew along the run ...
  EXPECT_GE(unchanged, 5u);  // ... and stayed between stops, where the kept map is handed out
  mapper.Flush();
  ExpectSnapshotShowsTheMapNow(mapper, "after the flush");

  // A mapper that took over saved maps, then dropped them for a frame that does not continue.
  const std::string saved = mapper.SaveState();
  MobileMapper resumed(testing::BumblebeeLikeCamera(), Params());
  ExpectSnapshotShowsTheMapNow(resumed, "fresh");
  ASSERT_TRUE(resumed.RestoreState(saved, nullptr));
  ExpectSnapshotShowsTheMapNow(resumed, "restored");
  EXPECT_EQ(resumed.Snapshot()->perceptual().segments.size(),
            mapper.Snapshot()->perceptual().segments.size());
  ASSERT_TRUE(resumed.AddKeyFrame(frames_->front()).restored_maps_dropped.has_value());
  ExpectSnapshotShowsTheMapNow(resumed, "dropped");
}

TEST_F(MobileMapperTest, RefusesBadKeyFramesAndKeepsTheMapsIntact) {
  MobileMapper mapper(testing::BumblebeeLikeCamera(), Params());
  const size_t half = frames_->size() / 2;
  for (size_t i = 0; i < half; ++i) mapper.AddKeyFrame((*frames_)[i]);
  mapper.Flush();
  const auto before = mapper.Snapshot();
  const KeyFrame& last = (*frames_)[half - 1];

  const auto refused = [&](KeyFrame f, const std::string& reason) {
    const auto r = mapper.AddKeyFrame(f);
    EXPECT_FALSE(r.accepted) << reason;
    ASSERT_TRUE(r.rejection.has_value()) << reason;
    EXPECT_EQ(r.rejection->reason, reason) << r.rejection->message;
    EXPECT_FALSE(r.rejection->message.empty());
  };
  KeyFrame back = last;  // going backwards in time
  back.stamp_ns -= 1'000'000;
  refused(back, "stamp_not_increasing");
  KeyFrame jump = last;  // odometry jumping 5 m in 0.2 s
  jump.stamp_ns += 200'000'000;
  jump.T_odom_base = last.T_odom_base * MakePose(5, 0, 0);
  refused(jump, "odometry_jump");
  KeyFrame nan = jump;
  nan.T_odom_base = MakePose(std::nan(""), 0, 0);
  refused(nan, "odometry_not_finite");
  KeyFrame pan = last;  // pan beyond the joint's limits
  pan.stamp_ns += 200'000'000;
  pan.joint_positions = {2.5};
  refused(pan, "joint_out_of_range");
  KeyFrame small = pan;
  small.joint_positions = {0.0};
  small.left = cv::Mat(120, 160, CV_8UC1, cv::Scalar(0));
  refused(small, "image_size");
  KeyFrame none = pan;
  none.joint_positions = {0.0};
  none.right = cv::Mat();
  refused(none, "image_missing");
  KeyFrame mask = pan;
  mask.joint_positions = {0.0};
  mask.moving = cv::Mat(120, 160, CV_8UC1, cv::Scalar(0));
  refused(mask, "moving_mask_size");
  KeyFrame depth = pan;
  depth.joint_positions = {0.0};
  depth.true_disparity = cv::Mat(last.left.size(), CV_8UC1, cv::Scalar(10));  // not float
  refused(depth, "true_disparity_size");

  const auto after = mapper.Snapshot();
  EXPECT_EQ(after->counters.rejected, 8u);
  EXPECT_EQ(after->counters.rejected_by_reason.at("odometry_jump"), 1u);
  EXPECT_EQ(after->poses.size(), before->poses.size());
  EXPECT_EQ(after->perceptual().segments.size(), before->perceptual().segments.size());
  EXPECT_EQ(after->grid.Export().occupancy, before->grid.Export().occupancy);
  // The run goes on where it was.
  EXPECT_TRUE(mapper.AddKeyFrame((*frames_)[half]).accepted);
}

// What moves on its own (KeyFrame::moving, in epmapd the EP's unexpected mask) gives the maps
// no point and the heading no feature.
TEST_F(MobileMapperTest, NothingIsTakenFromWhereSomethingMovesOnItsOwn) {
  const KeyFrame& f = (*frames_)[0];
  const auto measured = [&](const cv::Mat& moving) {
    MobileMapper mapper(testing::BumblebeeLikeCamera(), Params());
    KeyFrame k = f;
    k.moving = moving;
    return mapper.AddKeyFrame(k);
  };
  const auto all = measured(cv::Mat());
  ASSERT_GT(all.edge_points, 50u);
  ASSERT_GT(all.features, 20u);
  cv::Mat left_half(f.left.size(), CV_8UC1, cv::Scalar(0));
  left_half(cv::Rect(0, 0, f.left.cols / 2, f.left.rows)).setTo(255);
  const auto half = measured(left_half);
  EXPECT_TRUE(half.accepted);
  EXPECT_LT(half.edge_points, all.edge_points * 3 / 4);
  EXPECT_GT(half.edge_points, 0u);
  EXPECT_LT(half.features, all.features);
  const auto everything = measured(cv::Mat(f.left.size(), CV_8UC1, cv::Scalar(255)));
  EXPECT_TRUE(everything.accepted);
  EXPECT_EQ(everything.edge_points, 0u);
  EXPECT_EQ(everything.features, 0u);
  // The mask is grown so that a moving thing's outline goes too.
  cv::Mat dot(f.left.size(), CV_8UC1, cv::Scalar(0));
  dot.at<uint8_t>(60, 80) = 255;
  EXPECT_EQ(
      cv::countNonZero(mobile_mapping::GrowMovingMask(dot)),
      (2 * mobile_mapping::kMovingMaskGrowPx + 1) * (2 * mobile_mapping::kMovingMaskGrowPx + 1));
}

// The true depth (epmap-bench maps --true-depth) is taken where the true disparity is smooth,
// and nowhere near a depth edge or an unknown pixel.
TEST(TrueDepth, TakenWhereUnambiguousOnly) {
  const auto cam = testing::BumblebeeLikeCamera();
  cv::Mat d(cam.height, cam.width, CV_32FC1, cv::Scalar(15.0F));
  d(cv::Rect(200, 0, cam.width - 200, cam.height)).setTo(30.0F);  // a nearer surface
  d.at<float>(20, 20) = std::numeric_limits<float>::quiet_NaN();
  const auto p = mobile_mapping::TrueDepthOf(d, cam, 100.4F, 119.5F);
  ASSERT_TRUE(p.has_value());
  const double z = cam.fx * cam.baseline_m / 15.0;
  EXPECT_NEAR(p->z(), z, 1e-9);
  EXPECT_NEAR(p->x(), (100.4 - cam.cx) * z / cam.fx, 1e-6);  // u is a float
  EXPECT_NEAR(p->y(), 0.0, 1e-9);
  EXPECT_FALSE(mobile_mapping::TrueDepthOf(d, cam, 198.0F, 100.0F).has_value());  // edge
  EXPECT_TRUE(mobile_mapping::TrueDepthOf(d, cam, 196.0F, 100.0F).has_value());
  EXPECT_FALSE(mobile_mapping::TrueDepthOf(d, cam, 22.0F, 22.0F).has_value());  // unknown
  EXPECT_FALSE(mobile_mapping::TrueDepthOf(d, cam, -3.0F, 10.0F).has_value());  // outside
}

// Under --true-depth every map point of a key frame lies at the depth the true disparity
// gives: here a plane 2 m ahead of the camera, whatever the stereo measured in the room.
TEST_F(MobileMapperTest, MapPointsTakeTheTrueDepthWhenGiven) {
  const auto cam = testing::BumblebeeLikeCamera();
  const KeyFrame& f = (*frames_)[0];
  const double plane_z = 2.0;
  const auto occupied_off_plane = [&](const cv::Mat& true_disparity) {
    auto params = Params();
    params.view_min_key_frames = 1;  // one key frame makes a stop
    MobileMapper mapper(cam, params);
    KeyFrame k = f;
    k.true_disparity = true_disparity;
    EXPECT_TRUE(mapper.AddKeyFrame(k).accepted);
    mapper.Flush();
    const auto g = mapper.Snapshot()->grid.Export();
    // The camera looks along +x (pan 0, start pose): the plane's cells, plus the occupied
    // depth behind it and a cell either side for the lattice.
    const double x = f.T_base_cam.translation().x() + plane_z;
    int on = 0, off = 0;
    for (uint32_t r = 0; r < g.height; ++r) {
      for (uint32_t c = 0; c < g.width; ++c) {
        const uint8_t v = g.occupancy[r * g.width + c];
        if (v == occupancy::GridExport::kUnknown || v < 65) continue;
        const double cx = g.origin_x + (c + 0.5) * g.resolution_m;
        ++(std::abs(cx - x - 0.05) <= 0.2 ? on : off);
      }
    }
    return std::pair(on, off);
  };
  const auto [stereo_on, stereo_off] = occupied_off_plane(cv::Mat());
  EXPECT_GT(stereo_off, 10);  // the room's walls are not 2 m ahead
  const auto [true_on, true_off] = occupied_off_plane(cv::Mat(
      f.left.size(), CV_32FC1, cv::Scalar(static_cast<float>(cam.fx * cam.baseline_m / plane_z))));
  EXPECT_GT(true_on, 10);
  EXPECT_EQ(true_off, 0);
}

// Reference points come from every height between the limits but the skipped (furniture) band;
// the grid still gets its edge points from all heights.
TEST_F(MobileMapperTest, ReferencePointsSkipTheFurnitureBand) {
  const KeyFrame& f = (*frames_)[0];
  const auto report = [&](double from, double to) {
    auto p = Params();
    p.reference_skip_from_height_m = from;
    p.reference_skip_to_height_m = to;
    MobileMapper mapper(testing::BumblebeeLikeCamera(), p);
    return mapper.AddKeyFrame(f);
  };
  const auto no_band = report(0, 0), band = report(0.3, 1.2), everything = report(-1, 5);
  ASSERT_GT(no_band.reference_points, 50u);
  EXPECT_GT(band.reference_points, 0u);
  EXPECT_LT(band.reference_points, no_band.reference_points);
  EXPECT_EQ(everything.reference_points, 0u);
  EXPECT_EQ(everything.edge_points, no_band.edge_points);
  auto bad = Params();
  bad.reference_skip_to_height_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(MobileMapper(testing::BumblebeeLikeCamera(), bad), std::invalid_argument);
}

TEST_F(MobileMapperTest, AStopWithNoEdgesIsCountedNotFatal) {
  MobileMapper mapper(testing::BumblebeeLikeCamera(), Params());
  for (size_t i = 0; i < 6; ++i) mapper.AddKeyFrame((*frames_)[i]);
  // Two blank key frames at one new base pose (a stop facing a plain wall in the dark), then
  // the base moves on.
  const KeyFrame& last = (*frames_)[5];
  const cv::Mat blank(240, 320, CV_8UC1, cv::Scalar(90));
  KeyFrame a = last;
  a.stamp_ns += 1'000'000'000;
  a.T_odom_base = last.T_odom_base * MakePose(0.3, 0, 0);
  a.left = a.right = blank;
  KeyFrame b = a;
  b.stamp_ns += 200'000'000;
  b.T_base_cam = testing::CameraOnBase(0.4);
  b.joint_positions = {0.4};
  KeyFrame c = b;
  c.stamp_ns += 1'000'000'000;
  c.T_odom_base = b.T_odom_base * MakePose(0.3, 0, 0);
  const auto segments_before = mapper.Snapshot()->perceptual().segments.size();
  EXPECT_TRUE(mapper.AddKeyFrame(a).accepted);
  EXPECT_TRUE(mapper.AddKeyFrame(b).accepted);
  const auto r = mapper.AddKeyFrame(c);
  EXPECT_TRUE(r.accepted);
  EXPECT_TRUE(r.group_closed);
  EXPECT_TRUE(r.view_skipped);
  EXPECT_EQ(mapper.counters().views_without_objects, 1u);
  EXPECT_EQ(r.heading_source, localisation::HeadingSource::kOdometry);  // nothing to track
  EXPECT_GE(mapper.Snapshot()->perceptual().segments.size(), segments_before);
}

// The correlation's Kalman filter (odometry_drift_per_m > 0): trusting odometry (a tiny drift)
// leaves the poses where the run without any correlation puts them; with 0 the shifts are
// taken whole (paper 002).
TEST_F(MobileMapperTest, TheCorrelationFilterWeighsShiftsAgainstOdometryDrift) {
  const auto run = [](const mobile_mapping::MobileMapperParams& p) {
    MobileMapper mapper(testing::BumblebeeLikeCamera(), p);
    for (const auto& f : *frames_) EXPECT_TRUE(mapper.AddKeyFrame(f).accepted);
    mapper.Flush();
    return mapper.Snapshot();
  };
  auto p = Params();
  p.correlation_heading_step_rad = 0;  // the translation's filter alone
  p.odometry_drift_per_m = 0;
  const auto whole = run(p);
  ASSERT_GT(whole->counters.shifts_applied, 0u);  // the correlation moves this run
  p.map_correlation = false;
  const auto without = run(p);
  p.map_correlation = true;
  p.odometry_drift_per_m = 1e-6;
  const auto trusting = run(p);
  double most_apart = 0, whole_apart = 0;
  for (size_t k = 0; k < without->poses.size(); ++k) {
    const auto t = without->poses[k].T_world_base.translation();
    most_apart = std::max(most_apart, (trusting->poses[k].T_world_base.translation() - t).norm());
    whole_apart = std::max(whole_apart, (whole->poses[k].T_world_base.translation() - t).norm());
  }
  EXPECT_LT(most_apart, 1e-3);
  EXPECT_GT(whole_apart, 5e-3);
}

// A service restart: the maps saved after a closed stop, restored into a new mapper, go on
// exactly as the maps that never stopped (resuming at a key frame where the base stands, so
// that the heading does not need the previous key frame's features, which are not saved).
TEST_F(MobileMapperTest, SavedMapsResumeExactlyWhereTheyStopped) {
  size_t k = frames_->size() / 2;
  while (k + 1 < frames_->size() &&
         !((*frames_)[k].T_odom_base.matrix() == (*frames_)[k - 1].T_odom_base.matrix())) {
    ++k;
  }
  ASSERT_LT(k + 1, frames_->size()) << "no panning stop in the second half of the run";
  MobileMapper running(testing::BumblebeeLikeCamera(), Params());
  for (size_t i = 0; i < k; ++i) ASSERT_TRUE(running.AddKeyFrame((*frames_)[i]).accepted);
  running.Flush();
  const std::string saved = running.SaveState();
  ASSERT_GT(running.counters().views, 0u);

  // A service makes the mapper from the camera the state names, before any frame.
  std::string reason;
  const auto saved_camera = MobileMapper::SavedCamera(saved, &reason);
  ASSERT_TRUE(saved_camera.has_value()) << reason;
  const auto camera = testing::BumblebeeLikeCamera();
  EXPECT_EQ(saved_camera->width, camera.width);
  EXPECT_EQ(saved_camera->height, camera.height);
  EXPECT_EQ(saved_camera->fx, camera.fx);
  EXPECT_EQ(saved_camera->cy, camera.cy);
  EXPECT_EQ(saved_camera->baseline_m, camera.baseline_m);
  MobileMapper resumed(*saved_camera, Params());
  ASSERT_TRUE(resumed.RestoreState(saved, &reason)) << reason;
  EXPECT_TRUE(resumed.restore_unconfirmed());
  EXPECT_TRUE(resumed.Snapshot()->resumed_unconfirmed);
  EXPECT_FALSE(running.Snapshot()->resumed_unconfirmed);
  EXPECT_EQ(resumed.SaveState(), saved);  // byte for byte

  for (size_t i = k; i < frames_->size(); ++i) {
    const auto a = running.AddKeyFrame((*frames_)[i]);
    const auto b = resumed.AddKeyFrame((*frames_)[i]);
    ASSERT_TRUE(a.accepted && b.accepted);
    EXPECT_FALSE(b.restored_maps_dropped.has_value());
  }
  EXPECT_FALSE(resumed.restore_unconfirmed());
  EXPECT_FALSE(resumed.Snapshot()->resumed_unconfirmed);
  running.Flush();
  resumed.Flush();
  EXPECT_EQ(resumed.SaveState(), running.SaveState());
  const auto a = running.Snapshot(), b = resumed.Snapshot();
  ASSERT_EQ(a->perceptual().segments.size(), b->perceptual().segments.size());
  for (size_t i = 0; i < a->perceptual().segments.size(); ++i) {
    EXPECT_EQ(a->perceptual().segments[i].id, b->perceptual().segments[i].id);
    EXPECT_EQ(a->perceptual().segments[i].a, b->perceptual().segments[i].a);
  }
  EXPECT_EQ(a->grid.Export().occupancy, b->grid.Export().occupancy);
  EXPECT_EQ(a->poses.back().T_world_base.matrix(), b->poses.back().T_world_base.matrix());
  EXPECT_EQ(a->counters.views, b->counters.views);
}

// A state saved before the heading registration (format version 1: no heading turns counted,
// no heading filter) still resumes, with both at zero.
TEST_F(MobileMapperTest, AVersionOneStateStillResumes) {
  auto p = Params();
  p.correlation_heading_step_rad = 0.5 * kDeg;
  MobileMapper source(testing::BumblebeeLikeCamera(), p);
  for (size_t i = 0; i < frames_->size() / 3; ++i) source.AddKeyFrame((*frames_)[i]);
  source.Flush();
  const std::string v2 = source.SaveState();
  ASSERT_EQ(v2[8], 2);
  // From the end: "END." 4, last stamp 8, panning flag 1, then the heading filter (2 x f64);
  // before it the correlation filter (16 + 1 + 16), and before that the heading turns (u64).
  const size_t n = v2.size();
  std::string v1 = v2.substr(0, n - 70) + v2.substr(n - 62, 33) + v2.substr(n - 13);
  v1[8] = 1;
  MobileMapper resumed(testing::BumblebeeLikeCamera(), p);
  std::string reason;
  ASSERT_TRUE(resumed.RestoreState(v1, &reason)) << reason;
  EXPECT_EQ(resumed.counters().heading_turns, 0u);
  EXPECT_EQ(resumed.counters().views, source.counters().views);
  EXPECT_EQ(resumed.grid().Export().occupancy, source.grid().Export().occupancy);
  EXPECT_EQ(resumed.poses().latest().T_world_base.matrix(),
            source.poses().latest().T_world_base.matrix());
  // A version 1 state cut short or with bytes left over is still refused.
  MobileMapper other(testing::BumblebeeLikeCamera(), p);
  EXPECT_FALSE(other.RestoreState(v1.substr(0, v1.size() - 5) + "END.", &reason));
}

// Bytes that are not a whole state of this mapper's camera and lattice are refused with a
// reason, and the mapper is as new.
TEST_F(MobileMapperTest, BrokenOrForeignSavedMapsAreRefused) {
  MobileMapper source(testing::BumblebeeLikeCamera(), Params());
  for (size_t i = 0; i < frames_->size() / 3; ++i) source.AddKeyFrame((*frames_)[i]);
  source.Flush();
  const std::string saved = source.SaveState();
  const auto refused = [&](std::string_view bytes, const stereo::RectifiedGeometry& cam,
                           const mobile_mapping::MobileMapperParams& p, const std::string& why) {
    MobileMapper m(cam, p);
    std::string reason;
    EXPECT_FALSE(m.RestoreState(bytes, &reason)) << why;
    EXPECT_NE(reason.find(why), std::string::npos) << reason;
    EXPECT_FALSE(m.restore_unconfirmed());
    EXPECT_TRUE(m.poses().empty());
    EXPECT_TRUE(m.grid().empty());
    EXPECT_TRUE(m.AddKeyFrame(frames_->front()).accepted);  // and it maps as a new one
  };
  const auto cam = testing::BumblebeeLikeCamera();
  refused(std::string_view(saved).substr(0, saved.size() / 2), cam, Params(), "end early");
  refused(std::string_view(saved).substr(0, saved.size() - 1), cam, Params(), "");
  refused(saved + "x", cam, Params(), "follow the end mark");
  refused("not saved maps at all", cam, Params(), "header");
  std::string version = saved;
  version[8] = 7;
  refused(version, cam, Params(), "format version 7");
  // Nor is a camera read from them.
  for (const std::string_view bad :
       {std::string_view("not saved maps at all"), std::string_view(version),
        std::string_view(saved).substr(0, 20)}) {
    std::string reason;
    EXPECT_FALSE(MobileMapper::SavedCamera(bad, &reason).has_value());
    EXPECT_NE(reason.find("not readable"), std::string::npos) << reason;
  }
  auto other_cam = cam;
  other_cam.fx *= 1.01;
  refused(saved, other_cam, Params(), "another camera");
  auto coarse = Params();
  coarse.grid.resolution_m = 0.2;
  refused(saved, cam, coarse, "another lattice");
  // Not into a mapper that has maps of its own.
  MobileMapper busy(cam, Params());
  ASSERT_TRUE(busy.AddKeyFrame(frames_->front()).accepted);
  std::string reason;
  EXPECT_FALSE(busy.RestoreState(saved, &reason));
  EXPECT_NE(reason.find("already"), std::string::npos);
}

// After a restart the odometry may not be the frame the saved maps are in (the base restarted
// its odometry, the robot was carried): the first key frame tells, and new maps start.
TEST_F(MobileMapperTest, RestoredMapsAreDroppedWhenTheOdometryDoesNotContinue) {
  MobileMapper source(testing::BumblebeeLikeCamera(), Params());
  const size_t k = frames_->size() / 2;
  for (size_t i = 0; i < k; ++i) source.AddKeyFrame((*frames_)[i]);
  source.Flush();
  const std::string saved = source.SaveState();

  // A stamp from before the saved run's last one (another clock, a replay from the start).
  MobileMapper replay(testing::BumblebeeLikeCamera(), Params());
  ASSERT_TRUE(replay.RestoreState(saved, nullptr));
  auto r = replay.AddKeyFrame(frames_->front());
  ASSERT_TRUE(r.accepted);
  ASSERT_TRUE(r.restored_maps_dropped.has_value());
  EXPECT_NE(r.restored_maps_dropped->find("not after"), std::string::npos);
  EXPECT_EQ(replay.poses().records().size(), 1u);
  EXPECT_EQ(replay.counters().views, 0u);
  EXPECT_FALSE(replay.restore_unconfirmed());

  // Odometry restarted at zero, far from where the saved run stopped.
  MobileMapper carried(testing::BumblebeeLikeCamera(), Params());
  ASSERT_TRUE(carried.RestoreState(saved, nullptr));
  KeyFrame f = (*frames_)[k];
  f.T_odom_base = MakePose(5.0, 0.0, 0.0) * f.T_odom_base;
  r = carried.AddKeyFrame(f);
  ASSERT_TRUE(r.accepted);
  ASSERT_TRUE(r.restored_maps_dropped.has_value());
  EXPECT_NE(r.restored_maps_dropped->find("odometry moved"), std::string::npos);
  EXPECT_EQ(carried.poses().records().size(), 1u);

  // A key frame refused for another reason decides nothing; the next good one confirms.
  MobileMapper resumed(testing::BumblebeeLikeCamera(), Params());
  ASSERT_TRUE(resumed.RestoreState(saved, nullptr));
  KeyFrame small = (*frames_)[k];
  cv::resize(small.left, small.left, {}, 0.5, 0.5);
  EXPECT_FALSE(resumed.AddKeyFrame(small).accepted);
  EXPECT_TRUE(resumed.restore_unconfirmed());
  r = resumed.AddKeyFrame((*frames_)[k]);
  ASSERT_TRUE(r.accepted);
  EXPECT_FALSE(r.restored_maps_dropped.has_value());
  EXPECT_EQ(resumed.poses().records().size(), source.poses().records().size() + 1);
}

TEST(MobileMapper, BadConfigurationIsRefused) {
  auto cam = testing::BumblebeeLikeCamera();
  mobile_mapping::MobileMapperParams p;
  p.view_min_key_frames = -1;
  EXPECT_THROW(MobileMapper(cam, p), std::invalid_argument);
  p = {};
  p.odometry_drift_per_m = -0.01;
  EXPECT_THROW(MobileMapper(cam, p), std::invalid_argument);
  p = {};
  p.correlation_sigma_cells = 0;
  EXPECT_THROW(MobileMapper(cam, p), std::invalid_argument);
  for (const double step : {-0.01, 0.3, std::nan("")}) {
    p = {};
    p.correlation_heading_step_rad = step;
    EXPECT_THROW(MobileMapper(cam, p), std::invalid_argument);
  }
  p = {};
  p.correlation_heading_sigma_rad = 0;
  EXPECT_THROW(MobileMapper(cam, p), std::invalid_argument);
  p = {};
  p.heading_drift_per_rad = std::nan("");
  EXPECT_THROW(MobileMapper(cam, p), std::invalid_argument);
  cam.baseline_m = 0;
  EXPECT_THROW(MobileMapper(cam, {}), std::invalid_argument);
}

}  // namespace
}  // namespace epmap
