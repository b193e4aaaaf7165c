#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "perception/ep/comparator/regions.h"
#include "perception/ep/comparator/stereo_check.h"
#include "perception/ep/comparator/visual_comparator.h"
#include "tests/unit/ep/synthetic_scene.h"

namespace epmap {
namespace {

using ep::ComparatorParams;

// A textured predicted image (CV_32F) and an actual image equal to it.
void Images(cv::Mat* predicted, cv::Mat* actual) {
  cv::Mat noise(120, 160, CV_8U);
  cv::randu(noise, 40, 200);
  cv::GaussianBlur(noise, *actual, cv::Size(5, 5), 1.5);
  actual->convertTo(*predicted, CV_32F);
}

// Sec. IV-A on one pixel: E, C = (E + lambda C_-)/(lambda + 1), A = E exp(-alpha C_-^2).
TEST(VisualComparator, ImplementsThePapersEquations) {
  cv::Mat predicted(20, 20, CV_32F, cv::Scalar(100)), actual(20, 20, CV_8U, cv::Scalar(100));
  actual.at<uint8_t>(5, 5) = 130;
  cv::Mat c_pred(20, 20, CV_32F, cv::Scalar(0));
  c_pred.at<float>(5, 5) = 2.0F;
  const cv::Mat valid(20, 20, CV_8U, cv::Scalar(255));
  ComparatorParams p;
  p.compensate_exposure = false;
  p.unexpected_weight = 1.0;  // the paper's C everywhere
  p.threshold_grey = 1000;    // nothing flagged here
  const auto out = ep::Compare(predicted, valid, c_pred, actual, p);
  EXPECT_FLOAT_EQ(out.error.at<float>(5, 5), 30.0F);
  EXPECT_NEAR(out.accumulated.at<float>(5, 5), (30.0 + 10.0 * 2.0) / 11.0, 1e-5);
  EXPECT_NEAR(out.attenuated.at<float>(5, 5), 30.0 * std::exp(-0.1 * 4.0), 1e-4);
  EXPECT_FLOAT_EQ(out.error.at<float>(0, 0), 0.0F);
  EXPECT_NEAR(out.mean_error, 30.0 / 400.0, 1e-9);
  EXPECT_NEAR(out.mean_attenuated, 30.0 * std::exp(-0.4) / 400.0, 1e-6);
  // Above the threshold, the error feeds C with weight w: (w E + lambda C_-) / (w + lambda).
  p.threshold_grey = 10;
  p.min_region_area_px = 0;
  p.open_radius_px = p.close_radius_px = 0;
  p.unexpected_weight = 0.5;
  const auto weighted = ep::Compare(predicted, valid, c_pred, actual, p);
  EXPECT_NEAR(weighted.accumulated.at<float>(5, 5), (0.5 * 30.0 + 10.0 * 2.0) / 10.5, 1e-5);
  p.unexpected_weight = 0.0;
  EXPECT_FLOAT_EQ(ep::Compare(predicted, valid, c_pred, actual, p).accumulated.at<float>(5, 5),
                  2.0F);
}

TEST(VisualComparator, AttenuatesWhereErrorsAreHabitualAndKeepsNewOnesSalient) {
  cv::Mat predicted, actual;
  Images(&predicted, &actual);
  cv::Mat c_pred(actual.size(), CV_32F, cv::Scalar(0));
  c_pred(cv::Rect(0, 0, 40, 120)).setTo(10.0F);  // a habitually noisy band on the left
  cv::Mat changed = actual.clone();
  changed(cv::Rect(5, 40, 20, 20)) += 60;    // an error inside the noisy band
  changed(cv::Rect(100, 40, 20, 20)) += 60;  // and one where errors are unusual
  const cv::Mat valid(actual.size(), CV_8U, cv::Scalar(255));
  const auto out = ep::Compare(predicted, valid, c_pred, changed, ComparatorParams{});
  EXPECT_LT(cv::countNonZero(out.flagged(cv::Rect(0, 0, 40, 120))), 10);
  EXPECT_GT(cv::countNonZero(out.flagged(cv::Rect(100, 40, 20, 20))), 350);
  EXPECT_LT(out.mean_attenuated, out.mean_error);
  // The unexpected pixels feed C at half the weight of the others (w = 0.5, the default).
  EXPECT_NEAR(out.accumulated.at<float>(50, 110), out.error.at<float>(50, 110) * 0.5F / 10.5F,
              1e-4);
  EXPECT_GT(out.accumulated.at<float>(50, 60), -1.0F);
}

// A thing that moved a little: its new edge has no history, the rest overlaps where it was and
// has accumulated its own error (C_- high). A above the threshold finds only the edge; the
// growth through E recovers the whole thing, and nothing of the static scene.
TEST(VisualComparator, AFoundThingIsGrownOverItsPartsThatAttenuateThemselves) {
  cv::Mat predicted, actual;
  Images(&predicted, &actual);
  cv::Mat c_pred(actual.size(), CV_32F, cv::Scalar(0));
  cv::Mat changed = actual.clone();
  changed(cv::Rect(60, 40, 40, 30)) += 60;       // the thing, now
  c_pred(cv::Rect(60, 40, 34, 30)).setTo(8.0F);  // where it was: all but its 6-px leading edge
  const cv::Mat valid(actual.size(), CV_8U, cv::Scalar(255));
  ComparatorParams p;
  p.grow_threshold_grey = 0;
  const auto edge_only = ep::Compare(predicted, valid, c_pred, changed, p);
  EXPECT_LT(cv::countNonZero(edge_only.flagged), 400);
  p.grow_threshold_grey = 12;
  const auto grown = ep::Compare(predicted, valid, c_pred, changed, p);
  EXPECT_GE(cv::countNonZero(grown.flagged(cv::Rect(60, 40, 40, 30))), 40 * 30 - 20);
  EXPECT_LE(cv::countNonZero(grown.flagged), 40 * 30 + 20);
  // The attenuation itself is untouched: A is the paper's.
  EXPECT_LT(grown.attenuated.at<float>(55, 70), 1.0F);
  // Where the depth was a guess, nothing is grown over: the region stops there.
  cv::Mat guessed(actual.size(), CV_8U, cv::Scalar(0));
  guessed(cv::Rect(60, 40, 20, 30)).setTo(255);
  const auto stopped = ep::Compare(predicted, valid, c_pred, changed, p, {{}, guessed});
  EXPECT_LE(cv::countNonZero(stopped.flagged(cv::Rect(60, 40, 20, 30))), 60);
  EXPECT_GE(cv::countNonZero(stopped.flagged(cv::Rect(80, 40, 20, 30))), 20 * 30 - 20);
}

// A thing leaving the image has no new part: all of it overlaps where it was, and A is
// attenuated everywhere. Where it was found moving last frame (moved_before) and its error is
// still large, it stays found; without that nothing is.
TEST(VisualComparator, AThingFoundMovingStaysFoundWhileAllOfItOverlapsItself) {
  cv::Mat predicted, actual;
  Images(&predicted, &actual);
  cv::Mat changed = actual.clone();
  changed(cv::Rect(120, 40, 40, 30)) += 60;
  cv::Mat c_pred(actual.size(), CV_32F, cv::Scalar(0));
  c_pred(cv::Rect(120, 40, 40, 30)).setTo(8.0F);
  cv::Mat moved_before(actual.size(), CV_8U, cv::Scalar(0));
  moved_before(cv::Rect(116, 40, 44, 30)).setTo(2);
  moved_before(cv::Rect(10, 10, 20, 20)).setTo(2);  // moved, but nothing differs there now
  const cv::Mat valid(actual.size(), CV_8U, cv::Scalar(255));
  const ComparatorParams p;
  EXPECT_EQ(cv::countNonZero(ep::Compare(predicted, valid, c_pred, changed, p).flagged), 0);
  const auto followed = ep::Compare(predicted, valid, c_pred, changed, p, {moved_before, {}});
  EXPECT_GE(cv::countNonZero(followed.flagged(cv::Rect(120, 40, 40, 30))), 40 * 30 - 20);
  EXPECT_EQ(cv::countNonZero(followed.flagged(cv::Rect(0, 0, 60, 60))), 0);
  EXPECT_THROW(ep::Compare(predicted, valid, c_pred, changed, p, {cv::Mat(3, 3, CV_8U), {}}),
               std::invalid_argument);
  EXPECT_THROW(ep::Compare(predicted, valid, c_pred, changed, p, {{}, cv::Mat(3, 3, CV_8U)}),
               std::invalid_argument);
}

TEST(VisualComparator, GrowFromSeedsFollowsEightConnectedCandidatesOnly) {
  cv::Mat seeds(10, 10, CV_8U, cv::Scalar(0)), candidates(10, 10, CV_8U, cv::Scalar(0));
  seeds.at<uint8_t>(1, 1) = 255;
  for (int i = 2; i < 6; ++i) candidates.at<uint8_t>(i, i) = 1;  // a diagonal from the seed
  candidates.at<uint8_t>(8, 8) = 1;                              // not connected
  const cv::Mat grown = ep::GrowFromSeeds(seeds, candidates);
  EXPECT_EQ(cv::countNonZero(grown), 5);
  EXPECT_EQ(grown.at<uint8_t>(5, 5), 255);
  EXPECT_EQ(grown.at<uint8_t>(8, 8), 0);
}

TEST(VisualComparator, ExposureChangeIsNotUnexpected) {
  cv::Mat predicted, actual;
  Images(&predicted, &actual);
  cv::Mat brighter;
  actual.convertTo(brighter, CV_8U, 1.2, 5);
  const cv::Mat valid(actual.size(), CV_8U, cv::Scalar(255));
  const cv::Mat c_pred(actual.size(), CV_32F, cv::Scalar(0));
  ComparatorParams p;
  const auto compensated = ep::Compare(predicted, valid, c_pred, brighter, p);
  EXPECT_NEAR(compensated.gain, 1.2, 0.02);
  EXPECT_LT(compensated.mean_error, 1.0);
  EXPECT_EQ(cv::countNonZero(compensated.flagged), 0);
  p.compensate_exposure = false;
  const auto raw = ep::Compare(predicted, valid, c_pred, brighter, p);
  EXPECT_GT(raw.mean_error, 10.0);
}

TEST(VisualComparator, SpecksAreRemovedAndInvalidPixelsIgnored) {
  cv::Mat mask(60, 60, CV_8U, cv::Scalar(0));
  mask(cv::Rect(5, 5, 2, 2)).setTo(255);      // a speck
  mask(cv::Rect(20, 20, 15, 15)).setTo(255);  // a region
  const cv::Mat out = ep::RemoveSpecks(mask, 1, 40);
  EXPECT_EQ(cv::countNonZero(out(cv::Rect(0, 0, 10, 10))), 0);
  EXPECT_EQ(cv::countNonZero(out(cv::Rect(20, 20, 15, 15))), 225);
  cv::Mat predicted, actual;
  Images(&predicted, &actual);
  cv::Mat valid(actual.size(), CV_8U, cv::Scalar(255));
  valid(cv::Rect(0, 0, 80, 120)).setTo(0);
  predicted(cv::Rect(0, 0, 80, 120)).setTo(0);  // holes: nothing predicted
  const auto cmp = ep::Compare(predicted, valid, cv::Mat::zeros(actual.size(), CV_32F), actual);
  EXPECT_EQ(cv::countNonZero(cmp.flagged), 0);
  EXPECT_EQ(cmp.valid_pixels, 80 * 120);
  EXPECT_THROW(ep::Compare(predicted, valid, cv::Mat(), actual), std::invalid_argument);
}

TEST(Regions, BoxAreaDisparityAndCentroidInBothFrames) {
  stereo::RectifiedGeometry cam{160, 120, 100.0, 100.0, 79.5, 59.5, 0.1};
  cv::Mat mask(120, 160, CV_8U, cv::Scalar(0));
  cv::Mat disparity(120, 160, CV_32F, cv::Scalar(std::nan("")));
  mask(cv::Rect(70, 50, 20, 20)).setTo(255);
  disparity(cv::Rect(70, 50, 20, 20)).setTo(10.0F);  // z = 100 * 0.1 / 10 = 1 m
  mask(cv::Rect(5, 5, 3, 3)).setTo(255);             // a small one without disparity
  Eigen::Isometry3d T_base_cam0 = Eigen::Isometry3d::Identity();
  T_base_cam0.translation() = Eigen::Vector3d(1, 2, 3);
  const auto regions = ep::LabelRegions(mask, disparity, cam, T_base_cam0);
  ASSERT_EQ(regions.size(), 2u);
  EXPECT_EQ(regions[0].area_px, 400);
  EXPECT_EQ(regions[0].box, cv::Rect(70, 50, 20, 20));
  EXPECT_NEAR(regions[0].mean_disparity_px, 10.0, 1e-9);
  ASSERT_TRUE(regions[0].has_centroid);
  EXPECT_NEAR(regions[0].centroid_cam0.z(), 1.0, 1e-9);
  EXPECT_NEAR(regions[0].centroid_cam0.x(), (79.5 - 79.5) / 100.0, 1e-9);
  EXPECT_NEAR(regions[0].centroid_base.x(), 1.0, 1e-9);
  EXPECT_NEAR(regions[0].centroid_base.z(), 4.0, 1e-9);
  EXPECT_FALSE(regions[1].has_centroid);
  EXPECT_TRUE(std::isnan(regions[1].mean_disparity_px));
}

// A region on a moving thing holds some background at its edges; its centroid is the thing's.
TEST(Regions, TheCentroidIsThatOfTheMainSurfaceNotOfTheBackgroundAtItsEdges) {
  stereo::RectifiedGeometry cam{160, 120, 100.0, 100.0, 79.5, 59.5, 0.1};
  cv::Mat mask(120, 160, CV_8U, cv::Scalar(0));
  cv::Mat disparity(120, 160, CV_32F, cv::Scalar(std::nan("")));
  mask(cv::Rect(70, 50, 20, 20)).setTo(255);
  disparity(cv::Rect(70, 50, 16, 20)).setTo(10.0F);  // the thing, 1 m away (80%)
  disparity(cv::Rect(86, 50, 4, 20)).setTo(1.0F);    // the wall behind it, 10 m away (20%)
  disparity.at<float>(50, 70) = 10.5F;               // the thing is not flat
  const auto regions = ep::LabelRegions(mask, disparity, cam, Eigen::Isometry3d::Identity());
  ASSERT_EQ(regions.size(), 1u);
  ASSERT_TRUE(regions[0].has_centroid);
  // A mean over all points would put it at z = 0.8 * 1 + 0.2 * 10 = 2.8 m.
  EXPECT_NEAR(regions[0].centroid_cam0.z(), 1.0, 0.01);
  EXPECT_NEAR(regions[0].centroid_cam0.x(), (77.5 - 79.5) / 100.0, 0.01);  // the thing's middle
  EXPECT_NEAR(regions[0].mean_disparity_px, 0.8 * 10 + 0.2 * 1, 0.01);     // over all its pixels
  EXPECT_EQ(regions[0].disparity_pixels, 400);
}

// Our addition: the predicted disparity checked against the current pair.
TEST(StereoCheck, FindsWrongDisparitiesOnTexture) {
  const testing::SyntheticScene scene;
  cv::Mat l, r, d;
  scene.Render(testing::HeadPose(0, 0), &l, &r, &d);
  ep::StereoCheckParams p;
  p.enabled = true;
  const auto right = ep::CheckStereo(l, r, d, p);
  EXPECT_LT(cv::countNonZero(right.inconsistent), static_cast<int>(d.total() / 50));
  cv::Mat wrong = d.clone();
  wrong(cv::Rect(150, 60, 60, 60)) += 4.0F;  // 4 px off on the back wall
  const auto check = ep::CheckStereo(l, r, wrong, p);
  EXPECT_GT(cv::countNonZero(check.inconsistent(cv::Rect(150, 60, 60, 60))), 60 * 60 / 2);
}

}  // namespace
}  // namespace epmap
