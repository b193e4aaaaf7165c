#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <utility>
#include <vector>

#include "perception/ep/ep_settings.h"
#include "perception/ep/expected_perception.h"
#include "perception/stereo/metrics.h"
#include "perception/stereo/sgbm.h"
#include "tests/unit/ep/synthetic_scene.h"

namespace epmap {
namespace {

using ep::EpParams;
using ep::ExpectedPerception;
using ep::FrameMode;

EpParams Params() {
  EpParams p;
  p.sgbm.num_disparities = 48;
  return p;
}

struct Frame {
  cv::Mat left, right, disparity, square;
  Eigen::Isometry3d T_base_cam0;
  int64_t stamp_ns;
};

// Frame k of a head turning slowly left and right (yaw 0.06 sin(0.15 k) rad), with the square
// crossing the view at 1.2 m when `square` is set.
Frame Render(const testing::SyntheticScene& base, int k, bool square) {
  testing::SyntheticScene scene = base;
  if (square) scene.SetMovingSquare(Eigen::Vector3d(-0.45 + 0.03 * k, -0.05, 1.2));
  Frame f;
  f.T_base_cam0 = testing::HeadPose(0.06 * std::sin(0.15 * k), 0.02 * std::sin(0.1 * k));
  scene.Render(f.T_base_cam0, &f.left, &f.right, &f.disparity, &f.square);
  f.stamp_ns = 1'000'000'000LL + k * 33'333'333LL;
  return f;
}

double Iou(const cv::Mat& a, const cv::Mat& b) {
  const double uni = cv::countNonZero(a | b);
  return uni > 0 ? cv::countNonZero(a & b) / uni : 1.0;
}

TEST(ExpectedPerception, StillRigComputesOnceThenPredictsTheSameMap) {
  const testing::SyntheticScene scene;
  ExpectedPerception ep(scene.camera(), Params());
  const Frame f = Render(scene, 0, false);
  const auto first = ep.Process(f.left, f.right, f.T_base_cam0, f.stamp_ns);
  EXPECT_EQ(first->mode, FrameMode::kFirst);
  EXPECT_DOUBLE_EQ(first->recomputed_share, 1.0);
  for (int k = 1; k <= 5; ++k) {
    const auto res = ep.Process(f.left, f.right, f.T_base_cam0, f.stamp_ns + k);
    EXPECT_EQ(res->mode, FrameMode::kPredicted);
    EXPECT_TRUE(res->compared);
    EXPECT_EQ(cv::countNonZero(res->unexpected), 0);
    EXPECT_LT(res->mean_error, 0.5);
    // Only the rolling refresh band is recomputed: 1/5 of the rows on frame 4, nothing else.
    EXPECT_LT(res->recomputed_share, k == 4 ? 0.22 : 0.01) << "frame " << k;
    int same = 0, known = 0;
    for (int v = 0; v < f.left.rows; ++v) {
      for (int u = 0; u < f.left.cols; ++u) {
        const float a = first->disparity.at<float>(v, u), b = res->disparity.at<float>(v, u);
        if (std::isnan(a) && std::isnan(b)) continue;
        ++known;
        same += std::abs(a - b) < 0.5F;
      }
    }
    EXPECT_GT(same, known * 99 / 100) << "frame " << k;
  }
  EXPECT_EQ(ep.counters().frames, 6u);
  EXPECT_EQ(ep.counters().predicted, 5u);
}

// The rolling refresh re-measures every matchable pixel once per period, one band every
// rolling_every_frames frames (and nothing else on a still rig).
TEST(ExpectedPerception, TheRollingRefreshCoversTheImageOncePerPeriod) {
  const testing::SyntheticScene scene;
  const Frame f = Render(scene, 0, false);
  for (const int every : {1, 3, 4}) {
    EpParams p = Params();
    p.refresh.rolling_period_frames = 20;
    p.refresh.rolling_every_frames = every;
    ExpectedPerception ep(scene.camera(), p);
    ep.Process(f.left, f.right, f.T_base_cam0, f.stamp_ns);
    cv::Mat covered = cv::Mat::zeros(f.left.size(), CV_8U);
    for (int k = 1; k <= 20; ++k) {
      const auto res = ep.Process(f.left, f.right, f.T_base_cam0, f.stamp_ns + k);
      ASSERT_EQ(res->mode, FrameMode::kPredicted);
      const double rows_share = 1.0 / (20 / every);
      if (k % every == 0) {
        EXPECT_GT(res->recomputed_share, 0.5 * rows_share) << "every " << every << " frame " << k;
        EXPECT_LT(res->recomputed_share, 1.1 * rows_share) << "every " << every << " frame " << k;
      } else {
        EXPECT_LT(res->recomputed_share, 0.01) << "every " << every << " frame " << k;
      }
      covered |= res->recompute;
    }
    // Every row, across the columns SGBM can match (right of its search range's blind margin).
    const int first = p.sgbm.min_disparity + p.sgbm.num_disparities + p.sgbm.block_size;
    const cv::Mat matchable = covered(cv::Rect(first, 0, f.left.cols - first - 4, f.left.rows));
    EXPECT_EQ(cv::countNonZero(matchable), static_cast<int>(matchable.total()))
        << "every " << every;
  }
}

// The paper's experiment in small: a turning head, a square moving on its own. The unexpected
// mask finds the square; the map stays as good as full-frame SGBM; little is recomputed.
TEST(ExpectedPerception, FindsTheMovingSquareAndKeepsTheMapWhileTheHeadTurns) {
  const testing::SyntheticScene scene;
  const EpParams params = Params();
  ExpectedPerception ep(scene.camera(), params);
  const stereo::SgbmMatcher full(params.sgbm);
  std::vector<double> iou;
  stereo::DisparityScore ep_score, full_score;
  double share = 0;
  for (int k = 0; k < 24; ++k) {
    const Frame f = Render(scene, k, true);
    const auto res = ep.Process(f.left, f.right, f.T_base_cam0, f.stamp_ns);
    if (k < 3) continue;  // the first frames: C has no history yet
    EXPECT_EQ(res->mode, FrameMode::kPredicted);
    share += res->recomputed_share;
    if (cv::countNonZero(f.square) > 200) {
      iou.push_back(Iou(res->unexpected, f.square));
      ASSERT_FALSE(res->regions.empty());
      const auto& region = res->regions.front();
      EXPECT_TRUE(region.has_centroid);
      EXPECT_NEAR(region.centroid_cam0.z(), 1.2, 0.25) << "frame " << k;
    }
    const auto add = [](stereo::DisparityScore* total, const stereo::DisparityScore& s) {
      total->gt_pixels += s.gt_pixels;
      total->filled += s.filled;
      total->bad_filled += s.bad_filled;
    };
    add(&ep_score, stereo::ScoreDisparity(res->disparity, f.disparity));
    add(&full_score, stereo::ScoreDisparity(full.Compute(f.left, f.right), f.disparity));
  }
  ASSERT_GE(iou.size(), 10u);
  double mean_iou = 0;
  for (double x : iou) mean_iou += x / static_cast<double>(iou.size());
  EXPECT_GT(mean_iou, 0.5);
  EXPECT_LT(ep_score.bad_counting_unknown(), full_score.bad_counting_unknown() + 0.03);
  EXPECT_LT(share / 21.0, 0.35);
}

TEST(ExpectedPerception, AHeadWithoutMovingThingsFindsNothingUnexpected) {
  const testing::SyntheticScene scene;
  ExpectedPerception ep(scene.camera(), Params());
  for (int k = 0; k < 12; ++k) {
    const Frame f = Render(scene, k, false);
    const auto res = ep.Process(f.left, f.right, f.T_base_cam0, f.stamp_ns);
    EXPECT_LT(res->unexpected_share, 0.005) << "frame " << k;
  }
}

TEST(ExpectedPerception, APoseJumpIsComputedWholeAndCounted) {
  const testing::SyntheticScene scene;
  const Frame f0 = Render(scene, 0, false), f1 = Render(scene, 1, false),
              f2 = Render(scene, 2, false), f3 = Render(scene, 3, false);
  // An encoder glitch: 0.4 rad in 1/30 s, and back. Without earlier views the way back is a
  // jump too; with them (the default) the frame after the glitch is predicted from the map
  // the glitch left.
  for (const int earlier_views : {0, 4}) {
    EpParams params = Params();
    params.earlier_views = earlier_views;
    ExpectedPerception ep(scene.camera(), params);
    ep.Process(f0.left, f0.right, f0.T_base_cam0, f0.stamp_ns);
    const Eigen::Isometry3d glitch = testing::HeadPose(0.4, 0.0);
    const auto res = ep.Process(f1.left, f1.right, glitch, f1.stamp_ns);
    EXPECT_EQ(res->mode, FrameMode::kPoseJump);
    EXPECT_FALSE(res->compared);
    EXPECT_DOUBLE_EQ(res->recomputed_share, 1.0);
    EXPECT_EQ(cv::countNonZero(res->unexpected), 0);
    const auto back = ep.Process(f2.left, f2.right, f2.T_base_cam0, f2.stamp_ns);
    if (earlier_views == 0) {
      EXPECT_EQ(back->mode, FrameMode::kPoseJump);
      EXPECT_EQ(ep.counters().pose_jumps, 2u);
    } else {
      EXPECT_EQ(back->mode, FrameMode::kPredicted);
      EXPECT_TRUE(back->compared);
      EXPECT_LT(back->unexpected_share, 0.005);
      EXPECT_EQ(ep.counters().pose_jumps, 1u);
      EXPECT_EQ(ep.counters().from_earlier_view, 1u);
    }
    const auto next = ep.Process(f3.left, f3.right, f3.T_base_cam0, f3.stamp_ns);
    EXPECT_EQ(next->mode, FrameMode::kPredicted);
    EXPECT_LT(next->unexpected_share, 0.005);
  }
}

TEST(ExpectedPerception, AHeadPanningBackToAnEarlierViewIsPredictedFromIt) {
  // A look-around in steps beyond the bound (0.5 rad in 0.1 s): 0, -0.5, 0, +0.5, 0 rad. The
  // returns to 0 are predicted from the map left there, the frames out are computed whole; an
  // earlier view older than earlier_view_max_age_s is forgotten.
  const testing::SyntheticScene scene;
  const double yaws[] = {0.0, -0.5, 0.0, 0.5, 0.0};
  std::vector<Frame> frames;
  for (double yaw : yaws) {
    Frame f;
    f.T_base_cam0 = testing::HeadPose(yaw, 0.0);
    scene.Render(f.T_base_cam0, &f.left, &f.right);
    frames.push_back(f);
  }
  ExpectedPerception ep(scene.camera(), Params());
  std::vector<FrameMode> modes;
  for (size_t k = 0; k < frames.size(); ++k) {
    const auto res = ep.Process(frames[k].left, frames[k].right, frames[k].T_base_cam0,
                                static_cast<int64_t>(k + 1) * 100'000'000);
    modes.push_back(res->mode);
    if (res->mode == FrameMode::kPredicted) {
      EXPECT_TRUE(res->compared);
      EXPECT_LT(res->unexpected_share, 0.005) << "frame " << k;
      EXPECT_LT(res->recomputed_share, 0.3) << "frame " << k;
    }
  }
  EXPECT_EQ(modes,
            (std::vector<FrameMode>{FrameMode::kFirst, FrameMode::kPoseJump, FrameMode::kPredicted,
                                    FrameMode::kPoseJump, FrameMode::kPredicted}));
  EXPECT_EQ(ep.counters().from_earlier_view, 2u);

  EpParams short_memory = Params();
  short_memory.earlier_view_max_age_s = 0.15;  // the view at 0 is 0.2 s old when it returns
  ExpectedPerception forgetful(scene.camera(), short_memory);
  for (size_t k = 0; k < 3; ++k) {
    forgetful.Process(frames[k].left, frames[k].right, frames[k].T_base_cam0,
                      static_cast<int64_t>(k + 1) * 100'000'000);
  }
  EXPECT_EQ(forgetful.counters().from_earlier_view, 0u);
  EXPECT_EQ(forgetful.counters().pose_jumps, 2u);
}

TEST(ExpectedPerception, ThePoseJumpBoundIsARateNotAStepPerFrame) {
  // The same 0.2 rad turn is a jump 1/30 s after the last frame (6 rad/s, bound 4.5 rad/s) and
  // a turn to predict 1/10 s after it (2 rad/s: a slower camera, or a frame dropped). After a
  // 1 s dropout the interval counts as 0.25 s: 0.2 rad is predicted, a 1.5 rad glitch is not.
  const testing::SyntheticScene scene;
  const Frame f0 = Render(scene, 0, false);
  struct Case {
    int64_t interval_ns;
    double yaw;
    FrameMode expected;
  };
  for (const Case& c :
       {Case{33'333'333, 0.2, FrameMode::kPoseJump}, Case{100'000'000, 0.2, FrameMode::kPredicted},
        Case{1'000'000'000, 0.2, FrameMode::kPredicted},
        Case{1'000'000'000, 1.5, FrameMode::kPoseJump}}) {
    Frame turned;
    turned.T_base_cam0 = testing::HeadPose(c.yaw, 0.0);
    scene.Render(turned.T_base_cam0, &turned.left, &turned.right);
    ExpectedPerception ep(scene.camera(), Params());
    ep.Process(f0.left, f0.right, f0.T_base_cam0, f0.stamp_ns);
    const auto res =
        ep.Process(turned.left, turned.right, turned.T_base_cam0, f0.stamp_ns + c.interval_ns);
    EXPECT_EQ(res->mode, c.expected) << c.yaw << " rad after " << c.interval_ns << " ns";
    EXPECT_EQ(ep.counters().pose_jumps, c.expected == FrameMode::kPoseJump ? 1u : 0u);
  }
}

TEST(ExpectedPerception, BadInputIsRefusedAndTheStateKept) {
  const testing::SyntheticScene scene;
  ExpectedPerception ep(scene.camera(), Params());
  const Frame f0 = Render(scene, 0, false), f1 = Render(scene, 1, false);
  ep.Process(f0.left, f0.right, f0.T_base_cam0, f0.stamp_ns);
  const cv::Mat small = f1.left(cv::Rect(0, 0, 100, 100)).clone();
  EXPECT_THROW(ep.Process(small, small, f1.T_base_cam0, f1.stamp_ns), std::invalid_argument);
  cv::Mat float_image;
  f1.left.convertTo(float_image, CV_32F);
  EXPECT_THROW(ep.Process(float_image, f1.right, f1.T_base_cam0, f1.stamp_ns),
               std::invalid_argument);
  Eigen::Isometry3d nan_pose = f1.T_base_cam0;
  nan_pose.translation().y() = std::nan("");
  EXPECT_THROW(ep.Process(f1.left, f1.right, nan_pose, f1.stamp_ns), std::invalid_argument);
  Eigen::Isometry3d sheared = f1.T_base_cam0;
  sheared.matrix()(0, 1) += 0.1;
  EXPECT_THROW(ep.Process(f1.left, f1.right, sheared, f1.stamp_ns), std::invalid_argument);
  EXPECT_THROW(ep.Process(f1.left, f1.right, f1.T_base_cam0, f0.stamp_ns),
               std::invalid_argument);  // not after the previous frame
  EXPECT_EQ(ep.counters().frames, 1u);
  const auto res = ep.Process(f1.left, f1.right, f1.T_base_cam0, f1.stamp_ns);
  EXPECT_EQ(res->mode, FrameMode::kPredicted);
  EXPECT_THROW(ExpectedPerception(stereo::RectifiedGeometry{}, Params()), std::invalid_argument);
  EpParams bad = Params();
  bad.comparator.lambda = -1;
  EXPECT_THROW(ExpectedPerception(scene.camera(), bad), std::invalid_argument);
}

TEST(ExpectedPerception, ResultsNeverChangeAfterwards) {
  const testing::SyntheticScene scene;
  ExpectedPerception ep(scene.camera(), Params());
  std::shared_ptr<const ep::EpResult> kept;
  cv::Mat disparity, unexpected, error;
  for (int k = 0; k < 6; ++k) {
    const Frame f = Render(scene, k, true);
    const auto res = ep.Process(f.left, f.right, f.T_base_cam0, f.stamp_ns);
    if (k == 2) {
      kept = res;
      disparity = res->disparity.clone();
      unexpected = res->unexpected.clone();
      error = res->error.clone();
    }
  }
  // Equal, or NaN in both (OpenCV's comparisons are false for NaN).
  const cv::Mat same_d = (kept->disparity == disparity) |
                         (~(disparity == disparity) & ~(kept->disparity == kept->disparity));
  EXPECT_EQ(cv::countNonZero(same_d), static_cast<int>(disparity.total()));
  EXPECT_EQ(cv::norm(kept->unexpected, unexpected, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(kept->error, error, cv::NORM_INF), 0.0);
}

TEST(ExpectedPerception, RefreshPolicies) {
  const testing::SyntheticScene scene;
  EpParams every = Params();
  every.refresh.every_n_frames = 3;
  ExpectedPerception ep(scene.camera(), every);
  std::vector<FrameMode> modes;
  for (int k = 0; k < 7; ++k) {
    const Frame f = Render(scene, k, false);
    modes.push_back(ep.Process(f.left, f.right, f.T_base_cam0, f.stamp_ns)->mode);
  }
  const std::vector<FrameMode> expected = {
      FrameMode::kFirst,           FrameMode::kPredicted,
      FrameMode::kPredicted,       FrameMode::kRefreshScheduled,
      FrameMode::kPredicted,       FrameMode::kPredicted,
      FrameMode::kRefreshScheduled};
  EXPECT_EQ(modes, expected);
  EpParams share = Params();
  share.refresh.max_recompute_share = 1e-4;  // anything at all triggers a full frame:
  share.refresh.rolling_every_frames = 1;    // the refresh band of frame 1, at least
  ExpectedPerception ep2(scene.camera(), share);
  const Frame f0 = Render(scene, 0, false), f1 = Render(scene, 1, false);
  ep2.Process(f0.left, f0.right, f0.T_base_cam0, f0.stamp_ns);
  const auto res = ep2.Process(f1.left, f1.right, f1.T_base_cam0, f1.stamp_ns);
  EXPECT_EQ(res->mode, FrameMode::kRefreshShare);
  EXPECT_TRUE(res->compared);  // the comparison still ran
  EXPECT_EQ(ep2.counters().full_share, 1u);
}

// No burn-in: after a pan back and forth with the square passing, the map of the last frames
// is no worse than the map of the first ones.
TEST(ExpectedPerception, TheMapDoesNotDrift) {
  const testing::SyntheticScene scene;
  ExpectedPerception ep(scene.camera(), Params());
  stereo::DisparityScore early, late;
  const auto add = [](stereo::DisparityScore* total, const stereo::DisparityScore& s) {
    total->gt_pixels += s.gt_pixels;
    total->filled += s.filled;
    total->bad_filled += s.bad_filled;
  };
  for (int k = 0; k < 44; ++k) {
    const Frame f = Render(scene, k, k < 20);
    const auto res = ep.Process(f.left, f.right, f.T_base_cam0, f.stamp_ns);
    const auto s = stereo::ScoreDisparity(res->disparity, f.disparity);
    if (k >= 1 && k < 11) add(&early, s);
    if (k >= 34) add(&late, s);
  }
  EXPECT_LE(late.bad_counting_unknown(), early.bad_counting_unknown() + 0.01);
}

// The head tilts: a strip of new content appears along the top or the bottom border, thick
// enough to be worth its SGBM box. It is measured at once, whatever the other borders show (a
// strip along one border used to be deferred by the rule for the perpendicular borders, whose
// lines all cross it: it then stayed unknown until the rolling refresh came by).
TEST(ExpectedPerception, ANewStripAlongTheTopOrBottomIsMeasuredOnceThickEnough) {
  const testing::SyntheticScene scene;
  for (const double pitch : {0.04, -0.04}) {
    ExpectedPerception ep(scene.camera(), Params());
    const Frame f0 = Render(scene, 0, false);
    ep.Process(f0.left, f0.right, f0.T_base_cam0, f0.stamp_ns);
    Frame f1 = f0;
    f1.T_base_cam0 = testing::HeadPose(0.0, pitch);  // ~10 px of new rows at 1.2 rad/s
    scene.Render(f1.T_base_cam0, &f1.left, &f1.right, &f1.disparity, &f1.square);
    f1.stamp_ns += 33'333'333;
    const auto res = ep.Process(f1.left, f1.right, f1.T_base_cam0, f1.stamp_ns);
    ASSERT_EQ(res->mode, FrameMode::kPredicted);
    const cv::Mat holes = res->holes;
    const cv::Rect top(0, 0, holes.cols, 6), bottom(0, holes.rows - 6, holes.cols, 6);
    const cv::Rect strip =
        cv::countNonZero(holes(top)) > cv::countNonZero(holes(bottom)) ? top : bottom;
    const cv::Rect matchable(60, strip.y, holes.cols - 70, strip.height);  // SGBM's margins
    ASSERT_GT(cv::countNonZero(holes(matchable)), matchable.area() * 9 / 10) << pitch;
    EXPECT_GT(cv::countNonZero(res->recompute(matchable)), matchable.area() * 9 / 10) << pitch;
    int known = 0;
    for (int v = matchable.y; v < matchable.y + matchable.height; ++v) {
      for (int u = matchable.x; u < matchable.x + matchable.width; ++u) {
        known += std::isfinite(res->disparity.at<float>(v, u)) ? 1 : 0;
      }
    }
    EXPECT_GT(known, matchable.area() * 8 / 10) << pitch;
  }
}

// A still rig; something appears in front of a textured plane (disparity 10), at disparity 20,
// and for three frames the right camera cannot see it (its view there is blank: occluded). SGBM
// finds no match where the comparator flagged it; the map keeps a fill, unknown. Then the right
// camera sees it too: E notices nothing (the left image no longer changes), so only a retry of
// the unmatched pixels measures it; without retries it stays unknown.
TEST(ExpectedPerception, UnmatchedPixelsWhereSomethingMovedAreTriedAgain) {
  const int W = 320, H = 240, d_plane = 10, d_thing = 20;
  const cv::Rect thing(150, 90, 50, 50);
  cv::Mat plane(H, W + d_plane, CV_8U);
  cv::RNG rng(7);
  rng.fill(plane, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(plane, plane, {3, 3}, 0.8);
  const cv::Mat left0 = plane(cv::Rect(d_plane, 0, W, H)).clone();
  // The thing's texture differs from the plane's behind it by half the grey range everywhere.
  cv::Mat texture = left0(thing).clone();
  texture.forEach<uint8_t>([](uint8_t& g, const int*) { g = static_cast<uint8_t>(g + 128); });
  const cv::Mat right0 = plane(cv::Rect(0, 0, W, H)).clone();
  cv::Mat left1 = left0.clone(), right_blank = right0.clone(), right_seen = right0.clone();
  texture.copyTo(left1(thing));
  right_blank(cv::Rect(thing.x - d_thing, thing.y, thing.width + d_thing, thing.height)).setTo(128);
  texture.copyTo(right_seen(thing - cv::Point(d_thing, 0)));
  const stereo::RectifiedGeometry camera{W, H, 300.0, 300.0, 159.5, 119.5, 0.1};
  const auto known_share = [&](const cv::Mat& disparity) {
    const cv::Rect inner(thing.x + 5, thing.y + 5, thing.width - 10, thing.height - 10);
    int right = 0;
    for (int v = inner.y; v < inner.y + inner.height; ++v) {
      for (int u = inner.x; u < inner.x + inner.width; ++u) {
        right += std::abs(disparity.at<float>(v, u) - d_thing) <= 1.0F ? 1 : 0;  // NaN: no
      }
    }
    return static_cast<double>(right) / inner.area();
  };
  for (const int retries : {4, 0}) {
    EpParams p = Params();
    p.refresh.rolling_period_frames = 0;  // nothing else re-measures the thing
    p.retry_unmatched_frames = retries;
    ExpectedPerception ep(camera, p);
    const Eigen::Isometry3d still = Eigen::Isometry3d::Identity();
    int64_t stamp = 1'000'000'000;
    ep.Process(left0, right0, still, stamp);
    std::shared_ptr<const ep::EpResult> res;
    for (int k = 1; k <= 8; ++k) {
      res = ep.Process(left1, k <= 3 ? right_blank : right_seen, still, stamp += 33'333'333);
      ASSERT_EQ(res->mode, FrameMode::kPredicted);
      if (k == 1) {
        ASSERT_GT(cv::countNonZero(res->unexpected(thing)), thing.area() * 2 / 3);
        ASSERT_LT(known_share(res->disparity), 0.4);  // mostly unmatched: the right view is blank
      }
      if (k >= 4) {
        EXPECT_EQ(cv::countNonZero(res->unexpected(thing)), 0) << k;
      }
    }
    // Measured: 0.81 with retries, 0.23 (what frame 1 matched) without.
    if (retries > 0) {
      EXPECT_GT(known_share(res->disparity), 0.7);
    } else {
      EXPECT_LT(known_share(res->disparity), 0.4);
    }
  }
}

TEST(EpSettings, SetsListsAndRefuses) {
  EpParams p;
  ep::SetEpParam(&p, "comparator.threshold_grey", "21.5");
  ep::SetEpParam(&p, "refresh.rolling_period_frames", "7");
  ep::SetEpParam(&p, "comparator.compensate_exposure", "false");
  EXPECT_DOUBLE_EQ(p.comparator.threshold_grey, 21.5);
  EXPECT_EQ(p.refresh.rolling_period_frames, 7);
  EXPECT_FALSE(p.comparator.compensate_exposure);
  bool found = false;
  for (const auto& [k, v] : ep::ListEpParams(p)) {
    if (k == "comparator.lambda") {
      EXPECT_EQ(v, "10");  // the paper's forgetting factor
      found = true;
    }
  }
  EXPECT_TRUE(found);
  EXPECT_THROW(ep::SetEpParam(&p, "comparator.nope", "1"), std::invalid_argument);
  EXPECT_THROW(ep::SetEpParam(&p, "comparator.lambda", "ten"), std::invalid_argument);
  EXPECT_THROW(ep::SetEpParam(&p, "comparator.lambda", "10 px"), std::invalid_argument);
  EXPECT_THROW(ep::SetEpParam(&p, "remeasure_dynamic", "maybe"), std::invalid_argument);
}

}  // namespace
}  // namespace epmap
