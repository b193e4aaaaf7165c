#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "common/dataset/dataset.h"
#include "perception/stereo/metrics.h"
#include "perception/stereo/rectification.h"
#include "perception/stereo/sgbm.h"
#include "tests/support/test_env.h"

namespace epmap {
namespace {

// Our SGBM wrapper with the defaults reproduces the reference figure of ../shared/data's
// README for 'cones' (21.5% bad-2 counting unfilled pixels as wrong).
TEST(Sgbm, MatchesTheReferenceTableOnCones) {
  EPMAP_REQUIRE_SHARED_DATA("stereo-pairs/cones");
  const auto d = dataset::Load(testing::SharedDataDir() / "stereo-pairs/cones");
  const cv::Mat left = cv::imread(d.frames[0].left.string());
  const cv::Mat right = cv::imread(d.frames[0].right.string());
  stereo::SgbmParams p;
  p.num_disparities = d.num_disparities;
  const cv::Mat disp = stereo::ComputeDisparity(left, right, p);
  const auto score =
      stereo::ScoreDisparity(disp, dataset::LoadGtDisparity(d, d.frames[0].stamp_ns));
  EXPECT_NEAR(score.bad_counting_unknown(), 0.215, 0.002);
  EXPECT_NEAR(score.filled_share(), 0.831, 0.002);
}

TEST(Sgbm, RejectsBadParameters) {
  stereo::SgbmParams p;
  p.num_disparities = 50;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p.num_disparities = 64;
  p.block_size = 4;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
}

TEST(Rectification, EurocRectifiedPairHasRowAlignedGeometry) {
  EPMAP_REQUIRE_SHARED_DATA("euroc-v101-excerpt");
  const auto d = dataset::Load(testing::SharedDataDir() / "euroc-v101-excerpt");
  const auto K = [](const dataset::CameraSensor& c) {
    return cv::Matx33d(c.fu, 0, c.cu, 0, c.fv, c.cv, 0, 0, 1);
  };
  cv::Matx44d tl, tr;
  for (int i = 0; i < 16; ++i) {
    tl.val[i] = d.cam0.T_BS(i / 4, i % 4);
    tr.val[i] = d.cam1.T_BS(i / 4, i % 4);
  }
  stereo::CameraParameters l, r;
  stereo::StereoRectifyFromExtrinsics(K(d.cam0), d.cam0.distortion, K(d.cam1), d.cam1.distortion,
                                      tl, tr, cv::Size(d.cam0.width, d.cam0.height),
                                      d.cam0.distortion_model, &l, &r);
  const stereo::Rectifier rect(l, r);
  EXPECT_FALSE(rect.identity());
  EXPECT_NEAR(rect.geometry().baseline_m, d.baseline_m(), 1e-6);
  cv::Mat a, b;
  rect.Rectify(cv::imread(d.frames[0].left.string(), cv::IMREAD_GRAYSCALE),
               cv::imread(d.frames[0].right.string(), cv::IMREAD_GRAYSCALE), a, b);
  EXPECT_EQ(a.size(), cv::Size(752, 480));
}

// An already-rectified pinhole pair as CameraInfo carries it (REP 104: P[3] = -fx B on the
// right): the rectifier passes its images through and reads back the same geometry.
TEST(Rectification, APinholePairIsAlreadyRectified) {
  const auto [left, right] = camera::RectifiedPinholePair({320, 240, 277, 275, 160.5, 119.5}, 0.12);
  EXPECT_DOUBLE_EQ(right.p[3], -277 * 0.12);
  EXPECT_DOUBLE_EQ(right.baseline_from_p(), 0.12);
  EXPECT_DOUBLE_EQ(left.baseline_from_p(), 0.0);
  const stereo::Rectifier rect(left, right);
  EXPECT_TRUE(rect.identity());
  const auto& g = rect.geometry();
  EXPECT_EQ(g.width, 320);
  EXPECT_EQ(g.height, 240);
  EXPECT_DOUBLE_EQ(g.fx, 277);
  EXPECT_DOUBLE_EQ(g.fy, 275);
  EXPECT_DOUBLE_EQ(g.cx, 160.5);
  EXPECT_DOUBLE_EQ(g.cy, 119.5);
  EXPECT_NEAR(g.baseline_m, 0.12, 1e-12);
}

}  // namespace
}  // namespace epmap
