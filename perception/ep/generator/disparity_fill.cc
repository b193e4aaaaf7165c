#include "perception/ep/generator/disparity_fill.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace epmap::ep {

namespace {
constexpr float kSameSurfacePx = 2.0F;  // ends closer than this belong to one surface
}  // namespace

cv::Mat FillUnknownDisparity(const cv::Mat& disparity) {
  if (disparity.type() != CV_32FC1) throw std::invalid_argument("disparity must be CV_32FC1");
  cv::Mat out = disparity.clone();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int r = 0; r < out.rows; ++r) {
    float* row = out.ptr<float>(r);
    const auto valid = [&](int c) { return std::isfinite(row[c]) && row[c] > 0.0F; };
    int c = 0;
    while (c < out.cols) {
      if (valid(c)) {
        ++c;
        continue;
      }
      const int begin = c;
      while (c < out.cols && !valid(c)) ++c;
      const float left = begin > 0 ? row[begin - 1] : nan;
      const float right = c < out.cols ? row[c] : nan;
      if (std::isfinite(left) && std::isfinite(right) && std::abs(left - right) <= kSameSurfacePx) {
        // One surface on both sides: interpolate (a step would look like a depth edge).
        const float step = (right - left) / static_cast<float>(c - begin + 1);
        for (int i = begin; i < c; ++i) row[i] = left + step * static_cast<float>(i - begin + 1);
        continue;
      }
      float value = nan;
      if (std::isfinite(left) && std::isfinite(right)) {
        value = std::min(left, right);  // the background side
      } else if (std::isfinite(left)) {
        value = left;
      } else if (std::isfinite(right)) {
        value = right;
      }
      std::fill(row + begin, row + c, value);
    }
  }
  return out;
}

}  // namespace epmap::ep
