#include "perception/ep/generator/disparity_fill.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace epmap::ep {

namespace {
constexpr float kSameSurfacePx = 2.0F;  // ends closer than this belong to one surface

bool Known(float d) {
  return std::isfinite(d) && d > 0.0F;
}
}  // namespace

float FilledDisparityAt(const float* row, int width, int u, RowGap* gap) {
  if (Known(row[u])) return row[u];
  const float nan = std::numeric_limits<float>::quiet_NaN();
  if (!(u >= gap->begin && u < gap->end)) {
    int begin = u, end = u + 1;
    while (begin > 0 && !Known(row[begin - 1])) --begin;
    while (end < width && !Known(row[end])) ++end;
    *gap = {begin, end, begin > 0 ? row[begin - 1] : nan, end < width ? row[end] : nan};
  }
  const float left = gap->left, right = gap->right;
  if (std::isfinite(left) && std::isfinite(right) && std::abs(left - right) <= kSameSurfacePx) {
    // One surface on both sides: interpolate (a step would look like a depth edge).
    const float step = (right - left) / static_cast<float>(gap->end - gap->begin + 1);
    return left + step * static_cast<float>(u - gap->begin + 1);
  }
  if (std::isfinite(left) && std::isfinite(right)) return std::min(left, right);  // background
  if (std::isfinite(left)) return left;
  if (std::isfinite(right)) return right;
  return nan;
}

void FillUnknownDisparityRow(const float* in, float* out, int width) {
  RowGap gap;
  for (int u = 0; u < width; ++u) out[u] = FilledDisparityAt(in, width, u, &gap);
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
