#pragma once
// What a camera adds to the light that reaches it: a slight optical blur (which also softens
// the rendered silhouettes as real lenses do), a global gain (illumination flicker), additive
// Gaussian sensor noise and 8-bit quantisation.

#include <opencv2/core.hpp>

#include "clients/sim/random.h"

namespace epmap::sim {

struct SensorModel {
  double blur_sigma_px = 0.5;  // optics (point-spread function), pixels
  double noise_sigma = 2.0;    // grey levels, per channel; 0 = noiseless
};

// radiance (CV_32FC1 or CV_32FC3, 0..255) -> blur -> * gain -> + noise -> CV_8UC1/CV_8UC3.
// The noise is drawn from `rng`, so the same rng state gives the same image.
cv::Mat Expose(const cv::Mat& radiance, double gain, const SensorModel& sensor, Rng rng);

}  // namespace epmap::sim
