#pragma once
// Gives every pixel SGBM left unmatched a disparity to move with, so that the prediction
// covers them too (a map whose unknowns never moved would turn them into holes, and holes are
// recomputed: the EP would recompute SGBM's failures every frame). Along each row, a gap whose
// two ends differ by at most 2 px (one surface) is interpolated linearly; any other gap takes
// the smaller of its two ends (background-preferring, the usual choice for occlusions, which
// are SGBM's main failures). Filled pixels
// stay marked as unknown in the map's output; only their motion uses the fill.

#include <opencv2/core.hpp>

namespace epmap::ep {

// disparity: CV_32F with NaN (or <= 0) for unknown. Returns the filled copy (rows without
// any valid disparity stay NaN).
cv::Mat FillUnknownDisparity(const cv::Mat& disparity);

// The same for one row of `width` values (in and out must not overlap).
void FillUnknownDisparityRow(const float* in, float* out, int width);

// The same value at column u alone, for rows where few pixels need it: only the gap around u
// is looked at. The gap last found is remembered in `gap` (one per row; reset it for a new
// row), so the pixels of one gap cost one scan. Known values are returned as they are.
struct RowGap {
  int begin = 0, end = 0;  // [begin, end): the unknown run; empty = none remembered
  float left = 0, right = 0;
};
float FilledDisparityAt(const float* row, int width, int u, RowGap* gap);

}  // namespace epmap::ep
