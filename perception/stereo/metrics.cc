#include "perception/stereo/metrics.h"

#include <cmath>
#include <stdexcept>

namespace epmap::stereo {

double DisparityScore::bad_counting_unknown() const {
  return gt_pixels ? static_cast<double>(bad_filled + (gt_pixels - filled)) / gt_pixels : 0.0;
}
double DisparityScore::bad_over_filled() const {
  return filled ? static_cast<double>(bad_filled) / filled : 0.0;
}
double DisparityScore::filled_share() const {
  return gt_pixels ? static_cast<double>(filled) / gt_pixels : 0.0;
}

DisparityScore ScoreDisparity(const cv::Mat& estimate, const cv::Mat& truth, double threshold_px,
                              const cv::Mat& mask) {
  if (estimate.size() != truth.size() || estimate.type() != CV_32FC1 || truth.type() != CV_32FC1) {
    throw std::invalid_argument("ScoreDisparity: estimate and truth must be same-size CV_32FC1");
  }
  if (!mask.empty() && (mask.size() != truth.size() || mask.type() != CV_8UC1)) {
    throw std::invalid_argument("ScoreDisparity: mask must be CV_8UC1 of the same size");
  }
  DisparityScore s;
  for (int r = 0; r < truth.rows; ++r) {
    const float* t = truth.ptr<float>(r);
    const float* e = estimate.ptr<float>(r);
    const uint8_t* m = mask.empty() ? nullptr : mask.ptr<uint8_t>(r);
    for (int c = 0; c < truth.cols; ++c) {
      if (m && !m[c]) continue;
      if (!std::isfinite(t[c]) || t[c] <= 0.0F) continue;
      ++s.gt_pixels;
      if (!std::isfinite(e[c])) continue;
      ++s.filled;
      if (std::abs(e[c] - t[c]) > threshold_px) ++s.bad_filled;
    }
  }
  return s;
}

}  // namespace epmap::stereo
