#pragma once
// Pictures for people: disparity and float maps colour-mapped, unknown pixels black.

#include <opencv2/core.hpp>

namespace epmap::imaging {

// Colour-maps a CV_32FC1 map (TURBO) over [lo, hi]; non-finite pixels are black. If lo >= hi
// the range is taken from the finite values of the image.
cv::Mat ColorizeFloat(const cv::Mat& values, float lo = 0.0F, float hi = 0.0F);

// Scales a CV_32FC1 map to 8-bit grey over [0, hi] (hi <= 0: the image's maximum), NaN = 0.
cv::Mat FloatToGrey(const cv::Mat& values, float hi = 0.0F);

}  // namespace epmap::imaging
