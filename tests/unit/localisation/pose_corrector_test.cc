#include <gtest/gtest.h>

#include <numbers>

#include "perception/localisation/pose_corrector.h"

namespace epmap {
namespace {

using localisation::HeadingSource;
using localisation::MakePose;

constexpr double kDeg = std::numbers::pi / 180.0;

TEST(PoseCorrector, ReplacesTheOdometryHeadingChangeByTheVisualOne) {
  localisation::PoseCorrector pc;
  pc.Add(1, MakePose(0, 0, 0), std::nullopt);
  // Odometry: 1 m ahead while believing it turned 10 degrees; vision says 0.
  const auto& r = pc.Add(2, MakePose(std::cos(5 * kDeg), std::sin(5 * kDeg), 10 * kDeg), 0.0);
  EXPECT_EQ(r.heading_source, HeadingSource::kVisual);
  EXPECT_NEAR(localisation::HeadingOf(r.T_world_base), 0.0, 1e-12);
  // The chord keeps its length; its direction follows the corrected heading.
  EXPECT_NEAR(r.T_world_base.translation().x(), 1.0, 1e-9);
  EXPECT_NEAR(r.T_world_base.translation().y(), 0.0, 1e-9);
  EXPECT_NEAR(pc.LatestDifference().z(), -10 * kDeg, 1e-12);
}

TEST(PoseCorrector, StationaryKeepsTheHeadingAndFailuresFallBackToOdometry) {
  localisation::PoseCorrector pc;
  pc.Add(1, MakePose(0, 0, 0), std::nullopt);
  EXPECT_EQ(pc.Add(2, MakePose(0, 0, 0), 0.3).heading_source, HeadingSource::kStationary);
  const auto& r = pc.Add(3, MakePose(0, 0, 5 * kDeg), std::nullopt);
  EXPECT_EQ(r.heading_source, HeadingSource::kOdometry);
  EXPECT_NEAR(localisation::HeadingOf(r.T_world_base), 5 * kDeg, 1e-12);
  // A visual change 40 degrees away from the odometry's is refused.
  const auto& s = pc.Add(4, MakePose(0, 0, 10 * kDeg), 45 * kDeg);
  EXPECT_EQ(s.heading_source, HeadingSource::kOdometry);
  EXPECT_NEAR(localisation::HeadingOf(s.T_world_base), 10 * kDeg, 1e-12);
}

TEST(PoseCorrector, TranslationCorrectionAndBadInput) {
  localisation::PoseCorrector pc;
  pc.Add(1, MakePose(0, 0, 0), std::nullopt);
  pc.Add(2, MakePose(1, 0, 0), 0.0);
  pc.Add(3, MakePose(1, 0, 0), 0.0);
  pc.ApplyTranslation({0.1, -0.2}, 1);
  EXPECT_NEAR(pc.records()[0].T_world_base.translation().x(), 0.0, 1e-12);
  EXPECT_NEAR(pc.records()[1].T_world_base.translation().x(), 1.1, 1e-12);
  EXPECT_NEAR(pc.records()[2].T_world_base.translation().y(), -0.2, 1e-12);
  EXPECT_THROW(pc.Add(3, MakePose(1, 0, 0), 0.0), std::invalid_argument);  // not after
  EXPECT_THROW(pc.Add(4, MakePose(std::nan(""), 0, 0), 0.0), std::invalid_argument);
  EXPECT_EQ(pc.records().size(), 3u);
}

TEST(PoseCorrector, RotationCorrectionTurnsTheStopAndEverythingAfterIt) {
  localisation::PoseCorrector pc;
  pc.Add(1, MakePose(0, 0, 0), std::nullopt);
  pc.Add(2, MakePose(1, 0, 0), 0.0);
  pc.Add(3, MakePose(1, 0, 0), 0.0);
  // Turned by 90 degrees about (1, 0), the stop's position: it stays, its heading turns.
  pc.ApplyRotation(90 * kDeg, {1.0, 0.0}, 1);
  EXPECT_NEAR(localisation::HeadingOf(pc.records()[0].T_world_base), 0.0, 1e-12);
  EXPECT_NEAR(pc.records()[1].T_world_base.translation().x(), 1.0, 1e-12);
  EXPECT_NEAR(localisation::HeadingOf(pc.records()[2].T_world_base), 90 * kDeg, 1e-12);
  // Later key frames build on the turned heading: 1 m ahead is now along +y.
  const auto& r = pc.Add(4, MakePose(2, 0, 0), 0.0);
  EXPECT_NEAR(r.T_world_base.translation().x(), 1.0, 1e-9);
  EXPECT_NEAR(r.T_world_base.translation().y(), 1.0, 1e-9);
  // About another pivot the positions move on the circle around it.
  pc.ApplyRotation(-90 * kDeg, {0.0, 0.0}, 3);
  EXPECT_NEAR(pc.records()[3].T_world_base.translation().x(), 1.0, 1e-9);
  EXPECT_NEAR(pc.records()[3].T_world_base.translation().y(), -1.0, 1e-9);
  EXPECT_NEAR(localisation::HeadingOf(pc.records()[3].T_world_base), 0.0, 1e-12);
  EXPECT_THROW(pc.ApplyRotation(std::nan(""), {0.0, 0.0}, 0), std::invalid_argument);
  EXPECT_NEAR(pc.records()[3].T_world_base.translation().y(), -1.0, 1e-9);  // unchanged
}

}  // namespace
}  // namespace epmap
