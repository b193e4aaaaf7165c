#pragma once
// Dense disparity by OpenCV's Semi-Global Block Matching (the matcher paper 000 uses), with
// the parameters of the reference figures in ../shared/data/README.md as defaults.

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

namespace epmap::stereo {

struct SgbmParams {
  int min_disparity = 0;
  int num_disparities = 64;  // > 0, multiple of 16
  int block_size = 5;
  int p1 = 8 * 3 * 25;  // smoothness penalties, as in the reference table (8*3*block^2)
  int p2 = 32 * 3 * 25;
  int uniqueness_ratio = 10;
  int speckle_window = 100;
  int speckle_range = 32;
  int disp12_max_diff = 0;  // <= 0 disables the left-right check (OpenCV's default)
  int pre_filter_cap = 0;
  int mode = 2;  // cv::StereoSGBM::MODE_SGBM_3WAY (0 SGBM, 1 HH, 3 HH4)

  // Throws std::invalid_argument with the reason if the values cannot work.
  void Validate() const;
};

// Disparity of the left image in pixels (CV_32FC1), NaN where SGBM found no match. Images
// may be grey or BGR and must have the same size and type.
cv::Mat ComputeDisparity(const cv::Mat& left, const cv::Mat& right, const SgbmParams& params);

// A reusable matcher: creating the OpenCV object once saves its allocation per frame. Not
// thread-safe (OpenCV keeps work buffers in it): one matcher per thread.
class SgbmMatcher {
 public:
  explicit SgbmMatcher(const SgbmParams& params);
  cv::Mat Compute(const cv::Mat& left, const cv::Mat& right) const;
  const SgbmParams& params() const { return params_; }

 private:
  SgbmParams params_;
  cv::Ptr<cv::StereoMatcher> matcher_;
};

}  // namespace epmap::stereo
