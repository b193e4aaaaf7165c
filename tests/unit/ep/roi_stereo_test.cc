#include <gtest/gtest.h>

#include <cmath>

#include "perception/ep/update/roi_stereo.h"
#include "tests/unit/ep/synthetic_scene.h"

namespace epmap {
namespace {

stereo::SgbmParams Params() {
  stereo::SgbmParams p;
  p.num_disparities = 48;
  return p;
}

// SGBM in padded boxes gives (nearly) the full-frame values at the pixels it answers for, and
// touches nothing else.
TEST(RoiStereo, MatchesFullFrameSgbmInsideTheMask) {
  const testing::SyntheticScene scene;
  cv::Mat l, r, d;
  scene.Render(testing::HeadPose(0.02, 0.01), &l, &r, &d);
  ep::RoiStereo stereo(Params());
  const cv::Mat full = stereo.ComputeFull(l, r);
  cv::Mat mask(l.size(), CV_8U, cv::Scalar(0));
  mask(cv::Rect(150, 60, 40, 30)).setTo(255);
  mask(cv::Rect(300, 200, 15, 30)).setTo(255);  // at the right border
  cv::Mat disparity(l.size(), CV_32F, cv::Scalar(-7.0F));
  const auto stats = stereo.ComputeMasked(l, r, mask, disparity);
  EXPECT_EQ(stats.target_pixels, 40 * 30 + 15 * 30);
  EXPECT_LT(stats.computed_pixels, static_cast<long long>(l.total()) / 2);
  int same = 0, answered = 0;
  for (int v = 0; v < l.rows; ++v) {
    for (int u = 0; u < l.cols; ++u) {
      const float x = disparity.at<float>(v, u), f = full.at<float>(v, u);
      if (!mask.at<uint8_t>(v, u)) {
        ASSERT_EQ(x, -7.0F);
        continue;
      }
      ++answered;
      same += (std::isnan(x) && std::isnan(f)) || std::abs(x - f) <= 1.0F;
    }
  }
  EXPECT_GT(same, answered * 95 / 100);
}

// A band across the image (the rolling refresh) is split into pieces, each searching only the
// range expected in it, when that costs less than one box searching the range of the whole band;
// the pieces still give (nearly) the full-frame values.
TEST(RoiStereo, SplitsAWideBandIntoPiecesWithTheirOwnRanges) {
  const testing::SyntheticScene scene;
  cv::Mat l, r, truth;
  scene.Render(testing::HeadPose(0.02, 0.01), &l, &r, &truth);
  cv::Mat mask(l.size(), CV_8U, cv::Scalar(0));
  mask(cv::Rect(0, 100, l.cols, 24)).setTo(255);
  // What the map expects: the left half near, the right half far (as a band crossing a near
  // object and the background would).
  cv::Mat expected(l.size(), CV_32F, cv::Scalar(6.0F));
  expected(cv::Rect(0, 0, l.cols / 2, l.rows)).setTo(30.0F);
  ep::RoiStereoParams whole_band;
  whole_band.split_width_px = 0;
  ep::RoiStereo unsplit(Params(), whole_band), split(Params());
  cv::Mat d_unsplit(l.size(), CV_32F, cv::Scalar(-7.0F)), d_split = d_unsplit.clone();
  const auto a = unsplit.ComputeMasked(l, r, mask, d_unsplit, expected);
  const auto b = split.ComputeMasked(l, r, mask, d_split, expected);
  EXPECT_EQ(a.boxes, 1);
  EXPECT_EQ(b.boxes, 1);
  EXPECT_EQ(a.narrowed_boxes, 0);  // the whole band needs (nearly) the full range
  EXPECT_GE(b.narrowed_boxes, 1);
  EXPECT_LT(b.computed_pixels, a.computed_pixels * 3 / 4);
  EXPECT_EQ(b.target_pixels, a.target_pixels);
  for (int v = 0; v < l.rows; ++v) {
    for (int u = 0; u < l.cols; ++u) {
      if (!mask.at<uint8_t>(v, u)) {
        ASSERT_EQ(d_split.at<float>(v, u), -7.0F);
      }
    }
  }
  EXPECT_TRUE(cv::countNonZero(d_split(cv::Rect(0, 100, l.cols, 24)) == -7.0F) == 0);
}

TEST(RoiStereo, PlansBoxesThatDoNotCoverTheWholeImageForAnLShape) {
  ep::RoiStereo stereo(Params());
  cv::Mat mask(240, 320, CV_8U, cv::Scalar(0));
  mask(cv::Rect(0, 0, 320, 2)).setTo(255);    // newly visible top strip
  mask(cv::Rect(318, 0, 2, 240)).setTo(255);  // and right strip: one connected L
  const auto boxes = stereo.PlanBoxes(mask);
  long long area = 0;
  for (const auto& b : boxes) {
    area += b.padded.area();
    EXPECT_EQ(b.padded & cv::Rect(0, 0, 320, 240), b.padded);
    EXPECT_EQ(b.target & b.padded, b.target);
  }
  EXPECT_GE(boxes.size(), 2u);
  EXPECT_LT(area, 320 * 240 / 2);
  // The blind margins: SGBM never answers left of min+num disparities, nor in the last columns.
  EXPECT_EQ(stereo.first_matchable_column(), 48);
  EXPECT_EQ(stereo.last_matchable_column(320), 317);
}

TEST(RoiStereo, RejectsMismatchedInput) {
  ep::RoiStereo stereo(Params());
  const cv::Mat l(100, 100, CV_8U, cv::Scalar(0)), r(100, 90, CV_8U, cv::Scalar(0));
  cv::Mat d(100, 100, CV_32F), mask(100, 100, CV_8U, cv::Scalar(0));
  EXPECT_THROW(stereo.ComputeFull(l, r), std::invalid_argument);
  EXPECT_THROW(stereo.ComputeMasked(l, l, mask(cv::Rect(0, 0, 50, 50)), d), std::invalid_argument);
  ep::RoiStereoParams bad;
  bad.context_px = -1;
  EXPECT_THROW(ep::RoiStereo(Params(), bad), std::invalid_argument);
}

}  // namespace
}  // namespace epmap
