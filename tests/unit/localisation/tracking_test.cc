#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "perception/localisation/lorentzian_registration.h"
#include "perception/localisation/stereo_features.h"
#include "tests/support/planar_world.h"

namespace epmap {
namespace {

using testing::BaseInWorld;
using testing::CameraOnBase;

constexpr double kDeg = std::numbers::pi / 180.0;

struct Shot {
  cv::Mat left, right;
  Eigen::Isometry3d T_base_cam;
};

Shot Take(const testing::PlanarWorld& world, const Eigen::Vector3d& base, double pan,
          uint32_t seed) {
  const auto cam = testing::BumblebeeLikeCamera();
  Shot s;
  s.T_base_cam = CameraOnBase(pan);
  const Eigen::Isometry3d T_world_cam = BaseInWorld(base) * s.T_base_cam;
  Eigen::Isometry3d T_world_right = T_world_cam;
  T_world_right.translation() += T_world_cam.linear().col(0) * cam.baseline_m;
  s.left = world.Render(T_world_cam, cam, seed);
  s.right = world.Render(T_world_right, cam, seed + 1);
  return s;
}

TEST(StereoFeatures, DetectedPointsLieOnTheWalls) {
  const testing::PlanarWorld world(testing::RoomWalls());
  const Eigen::Vector3d base(2.0, 1.5, 0.3);
  const Shot s = Take(world, base, 0.2, 1);
  const localisation::StereoFeatureTracker tracker(testing::BumblebeeLikeCamera(), {});
  const auto kf = tracker.Detect(s.left, s.right, s.T_base_cam);
  ASSERT_GT(kf.features.size(), 25u);
  // Most points, in the world, lie on a wall (distance to the nearest wall segment in the
  // plane, relative to the range). The others are corners that are not points of the world:
  // T-junctions where a near wall's edge crosses a far wall's texture.
  const Eigen::Isometry3d T_world_cam = BaseInWorld(base) * s.T_base_cam;
  size_t on_wall = 0;
  for (const auto& f : kf.features) {
    const Eigen::Vector3d p = T_world_cam * f.p_cam;
    double best = 1e9;
    for (const auto& w : world.walls()) {
      const Eigen::Vector2d d = w.b - w.a;
      const double t = std::clamp((p.head<2>() - w.a).dot(d) / d.squaredNorm(), 0.0, 1.0);
      best = std::min(best, (p.head<2>() - (w.a + t * d)).norm());
    }
    on_wall += best < 0.02 * f.p_cam.z() + 0.02;
  }
  EXPECT_GE(on_wall * 100, kf.features.size() * 70);
}

// A known base motion (with a pan change) is recovered from the images: the visual heading
// change is accurate although the prediction it starts from (the "odometry") is 3 degrees off
// (the tracker starts there, the registration too).
void ExpectHeadingRecovered(double pan0, double pan1, const Eigen::Vector3d& base0,
                            const Eigen::Vector3d& base1) {
  const testing::PlanarWorld world(testing::RoomWalls());
  const Shot a = Take(world, base0, pan0, 10);
  const Shot b = Take(world, base1, pan1, 20);
  const localisation::StereoFeatureTracker tracker(testing::BumblebeeLikeCamera(), {});
  const auto ka = tracker.Detect(a.left, a.right, a.T_base_cam);
  const auto kb = tracker.Detect(b.left, b.right, b.T_base_cam);
  const Eigen::Isometry3d truth = BaseInWorld(base1).inverse() * BaseInWorld(base0);
  const Eigen::Isometry3d predicted =
      truth * Eigen::Isometry3d(Eigen::AngleAxisd(3 * kDeg, Eigen::Vector3d::UnitZ()));
  const auto pairs = tracker.Track(ka, kb, predicted);
  ASSERT_GT(pairs.x_prev.size(), 20u);
  // As the mobile mapper does it: the step's translation from the odometry (exact here), the
  // rotation about the vertical from the images.
  localisation::LorentzianParams lp;
  lp.vertical_axis_only = true;
  const auto fit = localisation::RegisterLorentzianRotation(pairs.x_prev, pairs.x_cur, pairs.sigma,
                                                            truth.inverse().translation(),
                                                            predicted.linear(), lp);
  ASSERT_TRUE(fit.ok) << fit.reason;
  const double dtheta = -localisation::YawOf(fit.T.linear());
  EXPECT_NEAR(dtheta, base1.z() - base0.z(), 0.05 * kDeg)
      << "pairs " << pairs.x_prev.size() << " inliers " << fit.inliers;
}

TEST(StereoFeatures, HeadingOfAStraightMove) {
  ExpectHeadingRecovered(0, 0, {2.0, 1.2, 0.0}, {2.3, 1.2, 0.0});
}
TEST(StereoFeatures, HeadingOfATurnInPlace) {
  ExpectHeadingRecovered(0, 0, {4.0, 1.2, 0.3}, {4.0, 1.2, 0.5});
}
TEST(StereoFeatures, HeadingOfAMoveWhileThePanChanges) {
  ExpectHeadingRecovered(0, 0.2, {2.0, 1.2, 0.0}, {2.1, 1.2, 0.0});
}

}  // namespace
}  // namespace epmap
