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
// Where we depart from the paper's equations by default: pixels found unexpected feed C at half
// weight (unexpected_weight; the paper's is 1). Our additions:
//   - exposure compensation: L_- is mapped by a robust global gain/offset fit to L before E is
//     taken, so that a global illumination change (flicker, auto-exposure) is not "unexpected";
//   - speck removal (opening, closing, minimum area) on the thresholded A;
//   - growth (hysteresis): a region found by A is grown over the adjacent pixels whose raw
//     error E is large but whose history attenuated it, and a thing found moving last frame is
//     followed while its error stays large (see grow_threshold_grey): the mask is the whole
//     moving thing, while A stays the paper's.

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
  // With w > 0 a moving thing attenuates itself wherever it overlaps where it was, so that A
  // stays above the threshold mostly on its new parts; the growth below recovers the rest of
  // it. With w = 0 the thing stays salient, but so do the static scene's occasional large
  // errors, and mean A / mean E (Fig. 6k) stays at 0.65. Measured (head scenario, 300 frames,
  // seeds 1 / 7: IoU median, settled mean A / mean E; building run with a person walking:
  // frames with the person found, of 111 compared):
  //   w = 0, no growth (before):  0.79 / 0.65;  0.65 / 0.58;  61
  //   w = 0.5, growth 12:         0.82 / 0.464; 0.78 / 0.472; 57
  // and, before growth stopped at guessed depths (PredictionHints::guessed):
  //   w = 0.3, growth 12:         0.84 / 0.489; 0.81 / 0.496; 61
  //   w = 0.5, growth 12:         0.84 / 0.465; 0.81 / 0.474; 57
  //   w = 1 (the paper), growth:  0.85 / 0.445; 0.81 / 0.453; 54
  //   w = 1, no growth:           0.17 / 0.40
  // 0.5 attenuates as Fig. 6k shows with a margin, at the cost of 4 of the walker's frames.
  double unexpected_weight = 0.5;
  // Hysteresis (our addition): a pixel whose raw error E is above this, but whose history
  // attenuated A to the threshold or below, joins the unexpected region that it touches
  // (8-connected, through other such pixels). Only what would be flagged without growth seeds
  // it, and pixels that moved on their own last frame (PredictionHints::moved_before) and are such
  // candidates: a thing found moving stays found while it leaves the image, when no part of it
  // is new. The attenuation is meant for the static scene's predictable errors, not for the
  // parts of a moving thing that overlap where it was. A large error without history is above
  // the threshold anyway: flagged on its own, or a speck. 0 disables.
  double grow_threshold_grey = 12.0;

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

// What the map knows about the predicted pixels beyond L_- and C_- (on the comparison grid,
// CV_8U, nonzero = yes; empty = nowhere).
struct PredictionHints {
  // The prediction comes from something that moved on its own last frame: followed by the
  // growth while its error stays large (see grow_threshold_grey).
  cv::Mat moved_before;
  // The prediction comes from a guessed depth (content SGBM never measured, in its blind
  // margins): compared, but never grown over. A guess is off by its parallax as soon as the
  // camera translates, and a region grown along such errors is a false one (building run, a
  // base driving past static walls: largest flagged area 2.3% of a frame with growth there,
  // 1.4% without; without growth at all 0.9%).
  cv::Mat guessed;
};

// predicted: L_- (CV_32F), valid: CV_8U 255 where L_- and C_- exist, predicted_accumulated:
// C_- (CV_32F), actual: L (CV_8U). Throws std::invalid_argument on mismatched inputs.
Comparison Compare(const cv::Mat& predicted, const cv::Mat& valid,
                   const cv::Mat& predicted_accumulated, const cv::Mat& actual,
                   const ComparatorParams& params = {}, const PredictionHints& hints = {});

// Robust least-squares fit actual ~ gain * predicted + offset over a grid of the valid pixels
// (one fit, then a refit without the pixels it explains worst). (1, 0) when too few pixels are
// valid or the fit is implausible (gain outside 0.5..2). predicted: CV_32F, valid and actual:
// CV_8U.
std::pair<double, double> FitGainOffset(const cv::Mat& predicted, const cv::Mat& valid,
                                        const cv::Mat& actual);

// The pixels of `candidates` (CV_8U, nonzero) 8-connected, through candidates, to a nonzero
// pixel of `seeds`, plus the seeds: 255, else 0.
cv::Mat GrowFromSeeds(const cv::Mat& seeds, const cv::Mat& candidates);

// Opening by a (2r+1)^2 square, then closing by a (2c+1)^2 square, then removal of 8-connected
// components smaller than min_area.
cv::Mat RemoveSpecks(const cv::Mat& mask, int open_radius_px, int min_area_px,
                     int close_radius_px = 0);

}  // namespace epmap::ep
