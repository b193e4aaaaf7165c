#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "perception/perceptual_map/perceptual_mapper.h"

namespace epmap {
namespace {

using perceptual_map::PerceptualMapper;

constexpr double kDeg = std::numbers::pi / 180.0;

struct Seg {
  Eigen::Vector2d a, b;
};

Eigen::Isometry2d Pose(double x, double y, double theta) {
  Eigen::Isometry2d T = Eigen::Isometry2d::Identity();
  T.linear() = Eigen::Rotation2Dd(theta).toRotationMatrix();
  T.translation() = Eigen::Vector2d(x, y);
  return T;
}

// Reference points a robot at T_world_base sees: wall points within range, every 2 cm, in the
// base frame, with a little noise (occlusion ignored: the test worlds are open corridors).
std::vector<Eigen::Vector2d> Points(const std::vector<Seg>& walls, const Eigen::Isometry2d& T,
                                    double range, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 0.01);
  std::vector<Eigen::Vector2d> out;
  for (const auto& w : walls) {
    const double len = (w.b - w.a).norm();
    for (double s = 0; s <= len; s += 0.02) {
      const Eigen::Vector2d p = w.a + (w.b - w.a) * (s / len);
      if ((p - T.translation()).norm() > range) continue;
      out.push_back(T.inverse() * p + Eigen::Vector2d(n(rng), n(rng)));
    }
  }
  return out;
}

double DistanceToWalls(const Eigen::Vector2d& p, const std::vector<Seg>& walls) {
  double best = 1e9;
  for (const auto& w : walls)
    best = std::min(best, perceptual_map::PointSegmentDistance(p, w.a, w.b));
  return best;
}

const std::vector<Seg> kCorridor = {{{-1, 1.0}, {25, 1.0}}, {{-1, -1.0}, {25, -1.0}},
                                    {{4, 1.0}, {4, 3.0}},   {{9, -1.0}, {9, -3.0}},
                                    {{14, 1.0}, {14, 2.5}}, {{19, -1.0}, {19, -2.5}}};

TEST(PerceptualMapper, TracksReferenceObjectsThroughAKnownMotion) {
  PerceptualMapper mapper;
  const auto p0 = Pose(2, 0, 0), p1 = Pose(2.6, 0.05, 8 * kDeg);
  mapper.AddView(1, Points(kCorridor, p0, 5, 1), p0);
  const auto r = mapper.AddView(2, Points(kCorridor, p1, 5, 2), p1);
  EXPECT_GT(r.objects, 10u);
  // Everything the second view sees within the first one's range is tracked (Eq. 5 through
  // the right motion).
  EXPECT_GE(r.tracked * 10, r.objects * 8);
  EXPECT_FALSE(r.expanded);

  // The same views with a motion 0.8 m off sideways: the transformed objects land on nothing.
  PerceptualMapper wrong;
  wrong.AddView(1, Points(kCorridor, p0, 5, 1), p0);
  const auto w = wrong.AddView(2, Points(kCorridor, p1, 5, 2), Pose(2.6, 0.85, 8 * kDeg));
  EXPECT_LT(w.tracked * 4, r.tracked);
}

TEST(PerceptualMapper, ExpandsWhenLeavingTheLocalEnvironmentAndPlacesObjectsOnTheWalls) {
  perceptual_map::PerceptualMapParams params;
  params.min_tracked = 10;
  PerceptualMapper mapper(params);
  size_t expansions = 0;
  for (int k = 0; k <= 20; ++k) {
    const auto T = Pose(k, 0.1 * std::sin(k), 0.02 * std::cos(k));
    expansions += mapper.AddView(k + 1, Points(kCorridor, T, 4, k), T).expanded;
  }
  EXPECT_GT(expansions, 2u);
  EXPECT_EQ(mapper.expansions(), expansions);
  const auto map = mapper.Map(false);
  ASSERT_GT(map.segments.size(), 30u);
  // Triangulated from common objects, the map stays on the walls (exact poses, 1 cm noise);
  // a grid cell holding a corner fits a line across it, a few centimetres off either wall.
  size_t on_wall = 0;
  for (const auto& s : map.segments) {
    EXPECT_LT(DistanceToWalls(s.a, kCorridor), 0.3) << s.id;
    EXPECT_LT(DistanceToWalls(s.b, kCorridor), 0.3) << s.id;
    on_wall += DistanceToWalls(s.a, kCorridor) < 0.05 && DistanceToWalls(s.b, kCorridor) < 0.05;
  }
  EXPECT_GE(on_wall * 10, map.segments.size() * 9);
  // Ids are unique, and the path runs along the corridor.
  std::set<uint32_t> ids;
  for (const auto& s : map.segments) ids.insert(s.id);
  EXPECT_EQ(ids.size(), map.segments.size());
  EXPECT_NEAR(map.path.back().x(), 20, 0.2);
  // Only views that joined the map hold segments.
  for (const auto& s : map.segments) EXPECT_TRUE(map.views[s.view_id - 1].in_map);
}

TEST(PerceptualMapper, TheAccumulatedTurnOrientsNewObjects) {
  // The pose estimate drifts in heading (as odometry does): 1 degree more per view. New
  // objects are placed with the accumulated turn of the pose, so the map bends with the drift
  // (the model corrects nothing), while successive views still track each other.
  perceptual_map::PerceptualMapParams params;
  params.min_tracked = 10;
  PerceptualMapper mapper(params);
  for (int k = 0; k <= 12; ++k) {
    const auto truth = Pose(k, 0, 0);
    const auto estimate = Pose(k, 0, k * 1.0 * kDeg);
    mapper.AddView(k + 1, Points(kCorridor, truth, 4, k), estimate);
  }
  const auto map = mapper.Map(false);
  double far_angle = 0;
  int n = 0;
  for (const auto& s : map.segments) {
    if (s.view_id < 8 || s.length() < 0.3) continue;
    const Eigen::Vector2d d = s.b - s.a;
    if (std::abs(d.y()) > std::abs(d.x())) continue;  // the corridor's long walls only
    far_angle += std::atan2(d.y(), d.x()) * (d.x() < 0 ? -1 : 1);
    ++n;
  }
  ASSERT_GT(n, 0);
  EXPECT_GT(far_angle / n, 4 * kDeg);
}

// A wall the first view saw only from x = 2.38 (occluded before) and the second from x = 2.0:
// the map's piece of the cell [2.0, 2.5) and the view's share an id but not their "left" end
// point, 0.38 m apart. A new object placed from that anchor lands 0.38 m off; the check against
// the robot's motion since the last map view leaves it out, and the next common object anchors.
TEST(PerceptualMapper, AnAnchorWhoseEndPointIsNotTheSamePhysicalPointIsNotUsed) {
  const Seg wall_seen_from_2_38{{2.38, 1.25}, {4.0, 1.25}};
  const Seg wall{{2.0, 1.25}, {4.0, 1.25}};
  const Seg new_wall{{2.25, 1.75}, {2.25, 2.75}};  // nearest to the cell [2.0, 2.5) of `wall`
  const auto place_new_wall = [&](double tolerance) {
    perceptual_map::PerceptualMapParams params;
    params.min_tracked = 1000;             // every view makes the previous one join the map
    params.anchor_length_agreement = 0.2;  // the short piece counts as agreeing in length
    params.anchor_motion_tolerance_m = tolerance;
    PerceptualMapper mapper(params);
    const auto p0 = Pose(0, 0, 0), p1 = Pose(0.1, 0, 0), p2 = Pose(0.2, 0, 0);
    mapper.AddView(1, Points({wall_seen_from_2_38}, p0, 10, 1), p0);
    mapper.AddView(2, Points({wall, new_wall}, p1, 10, 2), p1);
    mapper.AddView(3, Points({wall, new_wall}, p2, 10, 3), p2);  // view 2 joins the map
    double x = std::nan("");
    for (const auto& s : mapper.Map(false).segments) {
      if (s.view_id == 2 && std::abs(s.b.y() - s.a.y()) > 0.2) x = 0.5 * (s.a.x() + s.b.x());
    }
    return x;
  };
  EXPECT_NEAR(place_new_wall(0.0), 2.25 + 0.38, 0.05);  // no check: placed from the wrong end
  EXPECT_NEAR(place_new_wall(0.3), 2.25, 0.05);
}

TEST(PerceptualMapper, BlankViewsAndBadPosesLeaveTheMapIntact) {
  PerceptualMapper mapper;
  const auto T = Pose(2, 0, 0);
  mapper.AddView(10, Points(kCorridor, T, 4, 1), T);
  const auto before = mapper.Map(false).segments.size();
  const auto blank = mapper.AddView(11, {}, Pose(2.5, 0, 0));
  EXPECT_TRUE(blank.skipped);
  EXPECT_EQ(mapper.skipped_views(), 1u);
  EXPECT_THROW(mapper.AddView(12, Points(kCorridor, T, 4, 2), Pose(std::nan(""), 0, 0)),
               std::invalid_argument);
  EXPECT_THROW(mapper.AddView(5, Points(kCorridor, T, 4, 2), T), std::invalid_argument);
  EXPECT_EQ(mapper.Map(false).segments.size(), before);
  EXPECT_EQ(mapper.views(), 1u);
}

TEST(PerceptualMapper, TheLatestViewIsShownWithoutChangingTheMapper) {
  perceptual_map::PerceptualMapParams params;
  params.min_tracked = 1;  // never expands on its own here
  PerceptualMapper mapper(params);
  mapper.AddView(1, Points(kCorridor, Pose(0, 0, 0), 4, 1), Pose(0, 0, 0));
  mapper.AddView(2, Points(kCorridor, Pose(3, 0, 0), 4, 2), Pose(3, 0, 0));
  const auto committed = mapper.Map(false).segments.size();
  const auto shown = mapper.Map(true).segments.size();
  EXPECT_GT(shown, committed);
  EXPECT_EQ(mapper.Map(false).segments.size(), committed);
  EXPECT_EQ(mapper.Map(true).segments.size(), shown);
}

// Callers keep Map()'s result while the revision stays: it must change with everything that
// changes the map, and only then.
TEST(PerceptualMapper, TheRevisionChangesExactlyWhenTheMapMayChange) {
  PerceptualMapper mapper;
  const uint64_t fresh = mapper.revision();
  EXPECT_NE(PerceptualMapper().revision(), fresh);  // another mapper: never the same
  mapper.AddView(10, Points(kCorridor, Pose(2, 0, 0), 4, 1), Pose(2, 0, 0));
  const uint64_t one_view = mapper.revision();
  EXPECT_NE(one_view, fresh);
  mapper.AddView(11, {}, Pose(2.5, 0, 0));  // blank: the map stays
  EXPECT_EQ(mapper.revision(), one_view);
  EXPECT_THROW(mapper.AddView(5, Points(kCorridor, Pose(2, 0, 0), 4, 2), Pose(2, 0, 0)),
               std::invalid_argument);
  EXPECT_EQ(mapper.revision(), one_view);
  const PerceptualMapper copy = mapper;  // same map, same revision
  EXPECT_EQ(copy.revision(), one_view);
  mapper.AddView(12, Points(kCorridor, Pose(4, 0, 0), 4, 3), Pose(4, 0, 0));
  EXPECT_NE(mapper.revision(), one_view);
  EXPECT_EQ(copy.revision(), one_view);
  PerceptualMapper restored;
  const uint64_t before_restore = restored.revision();
  restored.Restore(mapper.SavedState());
  EXPECT_NE(restored.revision(), before_restore);
}

// The mapper finds a tracked object's segment by a binary search over the ids, so a saved
// state must keep them increasing (as the mapper appends them); a state that does not is
// refused whole and the mapper keeps its map. A restored map tracks and counts as the original.
TEST(PerceptualMapper, ARestoredMapTracksAsTheOriginalAndOneWithIdsOutOfOrderIsRefused) {
  PerceptualMapper mapper;
  for (int k = 0; k < 8; ++k) {
    const auto T = Pose(2 + 0.5 * k, 0, 0);
    mapper.AddView(10 + k, Points(kCorridor, T, 5, 20 + k), T);
  }
  const auto state = mapper.SavedState();
  ASSERT_GE(state.segments.size(), 3u);

  PerceptualMapper restored;
  restored.Restore(state);
  const auto T = Pose(6.5, 0, 0);
  const auto points = Points(kCorridor, T, 5, 99);
  const auto original_view = mapper.AddView(30, points, T);
  const auto restored_view = restored.AddView(30, points, T);
  EXPECT_GT(original_view.tracked, 0u);
  EXPECT_EQ(restored_view.tracked, original_view.tracked);
  const auto a = mapper.Map(false), b = restored.Map(false);
  ASSERT_EQ(a.segments.size(), b.segments.size());
  uint32_t observations = 0;
  for (size_t i = 0; i < a.segments.size(); ++i) {
    EXPECT_EQ(a.segments[i].id, b.segments[i].id);
    EXPECT_EQ(a.segments[i].observations, b.segments[i].observations);
    observations += a.segments[i].observations;
  }
  EXPECT_GT(observations, a.segments.size());  // tracked objects were counted again

  auto shuffled = state;
  std::swap(shuffled.segments[0], shuffled.segments[2]);
  PerceptualMapper refuses;
  refuses.Restore(mapper.SavedState());
  const auto before = refuses.Map(false);
  try {
    refuses.Restore(shuffled);
    ADD_FAILURE() << "a state with segment ids out of order was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("segment ids not increasing"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(refuses.Map(false).segments.size(), before.segments.size());
}

}  // namespace
}  // namespace epmap
