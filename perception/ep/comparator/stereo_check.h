#pragma once
// A check of the predicted disparity against the current stereo pair (our addition to paper
// 000's comparator). The paper's E compares the predicted and the real left image; under a
// mostly rotating head the predicted image barely depends on depth, so E cannot see a wrong
// disparity once the left image there has been refreshed (e.g. where a moving object was and
// is no longer: its disparity would stay in the map for good). The right image can: where the
// map is right, the left pixel (u, v) and the right pixel (u - d, v) show the same point, so
//   S(u, v) = mean over a window of |L(u, v) - g R(u - d(u, v), v) - o|
// (g, o a robust gain/offset fit between the cameras) stays at the noise level; where d is off
// by a few pixels on a textured surface, S is large. Regions where S exceeds the threshold
// (specks removed: SGBM's own values are slightly inconsistent along depth edges, and those
// thin fragments would otherwise be recomputed every frame) need a fresh SGBM.

#include <opencv2/core.hpp>

namespace epmap::ep {

struct StereoCheckParams {
  bool enabled = false;          // off by default: see the measurement in ../expected_perception.h
  double threshold_grey = 12.0;  // mean absolute difference over the window, grey levels
  int window_px = 5;             // averaging window (odd)
  int open_radius_px = 2;        // removes the thin fragments along depth edges
  int min_region_area_px = 100;

  void Validate() const;  // std::invalid_argument with the reason
};

struct StereoCheck {
  cv::Mat residual;      // S: CV_32F, NaN where the disparity is unknown or points outside R
  cv::Mat inconsistent;  // CV_8U 255: S above the threshold, specks removed
};

// left, right: CV_8U rectified pair; disparity: CV_32F (NaN = unknown, not checked).
StereoCheck CheckStereo(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity,
                        const StereoCheckParams& params = {});

}  // namespace epmap::ep
