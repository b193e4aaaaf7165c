#pragma once
// The visual comparator (paper 000, Sec. IV-A, Fig. 5 and 6):
//   E^{k+1} = |L_-^{k+1} - L^{k+1}|                       brightness error, grey levels
//   C^{k+1} = (E^{k+1} + lambda C_-^{k+1}) / (lambda + 1)  accumulated error, lambda = 10
//   A^{k+1} = E^{k+1} exp(-alpha (C_-^{k+1})^2)            attenuated error, alpha = 0.1
// and a threshold on A gives the unexpected regions.
//
// Reading of the garbled text (decided here and used everywhere):
//   - the paper prints the accumulation as "C_-^{k+1} = (E^{k+1} + lambda C_-^{k+1})/(lambda+1)"
//     with C_- on both sides; the left side is the new accumulated error C^{k+1}, which is what
//     the next frame propagates (C_-^{k+2} = p(C^{k+1}; ...)).
//   - the attenuation uses the propagated C_-^{k+1}, i.e. the history *before* this frame's
//     error, exactly as printed. With C^{k+1} instead, a new large error would attenuate itself
//     (E = 100 gives C >= 9 and exp(-0.1 * 81) ~ 3e-4): nothing unexpected could ever show.
//   - E, C and A are in grey levels of 8-bit images (0..255): alpha = 0.1 then attenuates a
//     pixel whose history holds ~3 grey levels of error by exp(-0.9) ~ 0.4 and one with ~7 by
//     exp(-4.9) ~ 0.007 (on a 0..1 scale alpha = 0.1 would do nothing at all).
//   - the threshold on A is not given in the paper: threshold_grey below (chosen by measurement).
// Our additions (off by default where they change the paper's equations):
//   - exposure compensation: L_- is mapped by a robust global gain/offset fit to L before E is
//     taken, so that a global illumination change (flicker, auto-exposure) is not "unexpected";
//   - speck removal (opening, minimum area) on the thresholded A.

#include <opencv2/core.hpp>
#include <utility>

namespace epmap::ep {

struct ComparatorParams {
  double lambda = 10.0;          // forgetting factor of the accumulated error (Sec. IV-A)
  double alpha = 0.1;            // attenuation strength (Sec. IV-A)
  double threshold_grey = 12.0;  // A above this is unexpected (not in the paper)
  bool compensate_exposure = true;
  int open_radius_px = 1;       // opening of the thresholded A (0 = none)
  int close_radius_px = 8;      // then closing: joins the fragments of one textured thing
  int min_region_area_px = 40;  // connected components smaller than this are dropped
  // How much the pixels found unexpected (A above the threshold) feed their error into C:
  //   C = (w E + lambda C_-) / (w + lambda) there (w = 1: the paper; w = 0: C = C_-).
  // 0 keeps a moving object from attenuating itself within a few frames while it overlaps its
  // previous position; persistent noise is still accumulated wherever it stays below the
  // threshold. Measured on the head scenario (300 frames, settled C): w = 0: IoU of the
  // unexpected mask 0.74 (mean), mean A / mean E 0.66; w = 0.1: 0.68, 0.59; w = 0.3: 0.40,
  // 0.48; w = 1: 0.22, 0.43. The robot wants the detector: 0.
  double unexpected_weight = 0.0;

  void Validate() const;  // std::invalid_argument with the reason
};

struct Comparison {
  cv::Mat error;                // E: CV_32F, 0 where the prediction is invalid
  cv::Mat accumulated;          // C: CV_32F, 0 where the prediction is invalid (no history)
  cv::Mat attenuated;           // A: CV_32F, 0 where the prediction is invalid
  cv::Mat flagged;              // CV_8U 255: A above the threshold, specks removed
  double mean_error = 0;        // mean of E over valid pixels (Fig. 6k, dash-dotted)
  double mean_attenuated = 0;   // mean of A over valid pixels (Fig. 6k, continuous)
  double gain = 1, offset = 0;  // exposure compensation applied: L_- -> gain * L_- + offset
  int valid_pixels = 0;
};

// predicted: L_- (CV_32F), valid: CV_8U 255 where L_- and C_- exist, predicted_accumulated:
// C_- (CV_32F), actual: L (CV_8U). Throws std::invalid_argument on mismatched inputs.
Comparison Compare(const cv::Mat& predicted, const cv::Mat& valid,
                   const cv::Mat& predicted_accumulated, const cv::Mat& actual,
                   const ComparatorParams& params = {});

// Robust least-squares fit actual ~ gain * predicted + offset over a grid of the valid pixels
// (one fit, then a refit without the pixels it explains worst). (1, 0) when too few pixels are
// valid or the fit is implausible (gain outside 0.5..2). predicted: CV_32F, valid and actual:
// CV_8U.
std::pair<double, double> FitGainOffset(const cv::Mat& predicted, const cv::Mat& valid,
                                        const cv::Mat& actual);

// Opening by a (2r+1)^2 square, then closing by a (2c+1)^2 square, then removal of 8-connected
// components smaller than min_area.
cv::Mat RemoveSpecks(const cv::Mat& mask, int open_radius_px, int min_area_px,
                     int close_radius_px = 0);

}  // namespace epmap::ep
