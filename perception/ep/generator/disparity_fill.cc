#include "perception/ep/generator/disparity_fill.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace epmap::ep {

namespace {
constexpr float kSameSurfacePx = 2.0F;  // ends closer than this belong to one surface
}  // namespace

void FillUnknownDisparityRow(const float* in, float* row, int width) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::copy(in, in + width, row);
  const auto valid = [&](int c) { return std::isfinite(row[c]) && row[c] > 0.0F; };
  int c = 0;
  while (c < width) {
    if (valid(c)) {
      ++c;
      continue;
    }
    const int begin = c;
    while (c < width && !valid(c)) ++c;
    const float left = begin > 0 ? row[begin - 1] : nan;
    const float right = c < width ? row[c] : nan;
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

cv::Mat FillUnknownDisparity(const cv::Mat& disparity) {
  if (disparity.type() != CV_32FC1) throw std::invalid_argument("disparity must be CV_32FC1");
  cv::Mat out(disparity.size(), CV_32FC1);
  for (int r = 0; r < out.rows; ++r) {
    FillUnknownDisparityRow(disparity.ptr<float>(r), out.ptr<float>(r), out.cols);
  }
  return out;
}

}  // namespace epmap::ep
