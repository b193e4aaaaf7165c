#include "perception/stereo/sgbm.h"

#include <limits>
#include <opencv2/calib3d.hpp>
#include <stdexcept>
#include <string>

namespace epmap::stereo {

void SgbmParams::Validate() const {
  if (num_disparities <= 0 || num_disparities % 16 != 0) {
    throw std::invalid_argument("num_disparities must be a positive multiple of 16, got " +
                                std::to_string(num_disparities));
  }
  if (num_disparities > 1024) throw std::invalid_argument("num_disparities must be <= 1024");
  if (block_size < 1 || block_size % 2 == 0 || block_size > 31) {
    throw std::invalid_argument("block_size must be odd in 1..31, got " +
                                std::to_string(block_size));
  }
  if (p1 < 0 || p2 <= p1) throw std::invalid_argument("SGBM needs 0 <= p1 < p2");
  if (mode < 0 || mode > 3) throw std::invalid_argument("SGBM mode must be 0..3");
}

SgbmMatcher::SgbmMatcher(const SgbmParams& params) : params_(params) {
  params_.Validate();
  matcher_ = cv::StereoSGBM::create(params.min_disparity, params.num_disparities, params.block_size,
                                    params.p1, params.p2, params.disp12_max_diff,
                                    params.pre_filter_cap, params.uniqueness_ratio,
                                    params.speckle_window, params.speckle_range, params.mode);
}

cv::Mat SgbmMatcher::Compute(const cv::Mat& left, const cv::Mat& right) const {
  if (left.size() != right.size() || left.type() != right.type()) {
    throw std::invalid_argument("left and right images differ in size or type");
  }
  cv::Mat fixed;
  matcher_->compute(left, right, fixed);  // CV_16S, disparity * 16
  cv::Mat out(fixed.size(), CV_32FC1);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // SGBM marks "no match" with (min_disparity - 1) * 16.
  const int invalid_below = params_.min_disparity * 16;
  for (int r = 0; r < fixed.rows; ++r) {
    const auto* in = fixed.ptr<int16_t>(r);
    auto* o = out.ptr<float>(r);
    for (int c = 0; c < fixed.cols; ++c) {
      o[c] = in[c] < invalid_below ? nan : static_cast<float>(in[c]) * (1.0F / 16.0F);
    }
  }
  return out;
}

cv::Mat ComputeDisparity(const cv::Mat& left, const cv::Mat& right, const SgbmParams& params) {
  return SgbmMatcher(params).Compute(left, right);
}

}  // namespace epmap::stereo
