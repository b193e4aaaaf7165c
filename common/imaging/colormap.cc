#include "common/imaging/colormap.h"

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace epmap::imaging {

namespace {
void FiniteRange(const cv::Mat& values, float& lo, float& hi) {
  lo = std::numeric_limits<float>::max();
  hi = std::numeric_limits<float>::lowest();
  for (int r = 0; r < values.rows; ++r) {
    const float* row = values.ptr<float>(r);
    for (int c = 0; c < values.cols; ++c) {
      if (std::isfinite(row[c])) {
        lo = std::min(lo, row[c]);
        hi = std::max(hi, row[c]);
      }
    }
  }
  if (lo > hi) {
    lo = 0.0F;
    hi = 1.0F;
  }
}
}  // namespace

cv::Mat ColorizeFloat(const cv::Mat& values, float lo, float hi) {
  CV_Assert(values.type() == CV_32FC1);
  if (!(lo < hi)) FiniteRange(values, lo, hi);
  const float span = std::max(hi - lo, 1e-6F);
  cv::Mat grey(values.size(), CV_8UC1);
  cv::Mat unknown(values.size(), CV_8UC1);
  for (int r = 0; r < values.rows; ++r) {
    const float* in = values.ptr<float>(r);
    auto* out = grey.ptr<uint8_t>(r);
    auto* bad = unknown.ptr<uint8_t>(r);
    for (int c = 0; c < values.cols; ++c) {
      const bool finite = std::isfinite(in[c]);
      const float t = finite ? std::clamp((in[c] - lo) / span, 0.0F, 1.0F) : 0.0F;
      out[c] = static_cast<uint8_t>(std::lround(t * 255.0F));
      bad[c] = finite ? 0 : 255;
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar::all(0), unknown);
  return colour;
}

cv::Mat FloatToGrey(const cv::Mat& values, float hi) {
  CV_Assert(values.type() == CV_32FC1);
  if (hi <= 0.0F) {
    float lo = 0.0F;
    FiniteRange(values, lo, hi);
  }
  const float scale = 255.0F / std::max(hi, 1e-6F);
  cv::Mat grey(values.size(), CV_8UC1);
  for (int r = 0; r < values.rows; ++r) {
    const float* in = values.ptr<float>(r);
    auto* out = grey.ptr<uint8_t>(r);
    for (int c = 0; c < values.cols; ++c) {
      out[c] =
          std::isfinite(in[c]) ? static_cast<uint8_t>(std::clamp(in[c] * scale, 0.0F, 255.0F)) : 0;
    }
  }
  return grey;
}

}  // namespace epmap::imaging
