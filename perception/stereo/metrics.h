#pragma once
// Disparity quality against ground truth, as the reference table in ../shared/data/README.md
// measures it.

#include <opencv2/core.hpp>

namespace epmap::stereo {

struct DisparityScore {
  size_t gt_pixels = 0;   // pixels with a known true disparity (inside the mask, if any)
  size_t filled = 0;      // of those, pixels the estimate filled
  size_t bad_filled = 0;  // filled and off by more than the threshold
  double bad_counting_unknown() const;  // (bad_filled + unfilled) / gt_pixels
  double bad_over_filled() const;       // bad_filled / filled
  double filled_share() const;          // filled / gt_pixels
};

// Scores estimate against truth (both CV_32FC1, non-finite or <= 0 truth = unknown). `mask`
// (CV_8UC1, optional) restricts the pixels scored.
DisparityScore ScoreDisparity(const cv::Mat& estimate, const cv::Mat& truth,
                              double threshold_px = 2.0, const cv::Mat& mask = cv::Mat());

}  // namespace epmap::stereo
