#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "common/imaging/pfm.h"
#include "tests/support/test_env.h"

namespace epmap {
namespace {

TEST(Pfm, RoundTripKeepsValuesAndUnknowns) {
  cv::Mat image(7, 5, CV_32FC1);
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) image.at<float>(r, c) = r * 10.0F + c * 0.25F;
  }
  image.at<float>(3, 2) = std::numeric_limits<float>::quiet_NaN();
  const auto dir = testing::FreshTempDir("pfm");
  imaging::WritePfm(dir / "a.pfm", image);
  const cv::Mat back = imaging::ReadPfm(dir / "a.pfm");
  ASSERT_EQ(back.size(), image.size());
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      if (r == 3 && c == 2) {
        EXPECT_TRUE(std::isnan(back.at<float>(r, c)));
      } else {
        EXPECT_EQ(back.at<float>(r, c), image.at<float>(r, c));
      }
    }
  }
  std::filesystem::remove_all(dir);
}

TEST(Pfm, RejectsGarbageWithReason) {
  const auto dir = testing::FreshTempDir("pfm-bad");
  { std::ofstream(dir / "bad.pfm") << "P6\n1 1\n255\nxyz"; }
  EXPECT_THROW(imaging::ReadPfm(dir / "bad.pfm"), std::runtime_error);
  EXPECT_THROW(imaging::ReadPfm(dir / "missing.pfm"), std::runtime_error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace epmap
