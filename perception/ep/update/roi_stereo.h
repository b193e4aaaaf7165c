#pragma once
// The disparity update of the EP scheme (paper 000, Sec. IV-B: "only these areas are updated
// reducing the computation time"): OpenCV's SGBM (the paper's matcher) run only on padded boxes
// around the regions that need it, the fresh values written into the map at those regions'
// pixels only.
//
// Padding gives the matcher the context it would have had on the full frame:
//   - half a block plus `context_px` on every side (block matching and SGBM's path costs);
//   - to the left, also the whole search range (min_disparity + num_disparities): a left pixel
//     at x is matched against right pixels down to x - max disparity, and SGBM leaves the first
//     max-disparity columns of whatever it is given without a value.
// Planning: the mask is cut into horizontal bands, each band's connected pieces give tight
// boxes, and boxes are merged greedily whenever one padded box costs no more than two (an
// L-shaped or diagonal region thus never turns into one box covering the whole image).

#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "perception/stereo/sgbm.h"

namespace epmap::ep {

struct RoiStereoParams {
  // Beyond half a block, on every side. Measured on the head scenario (300 frames): 2 instead
  // of 4 saves ~7% of the SGBM work for +0.06 points of bad-2 and -0.003 IoU.
  int context_px = 2;
  int band_rows = 24;  // height of the bands the mask is cut into before merging
  // Boxes are merged when area(union) <= merge_slack * (area(a) + area(b)).
  double merge_slack = 1.0;
  // When the caller knows roughly what disparity to expect in a box, SGBM searches only
  // [min - margin, max + margin] there (margin = range_margin_px + range_margin_share * max),
  // rounded to SGBM's steps of 16: cost and left padding both scale with the search range.
  // Measured on the head scenario: 3 px + 10% instead of 6 px + 25% saves ~7% of the SGBM work
  // with bad-2 unchanged (0.1417 vs 0.1419); 2 px + 5% saves ~2% more.
  double range_margin_px = 3.0;
  double range_margin_share = 0.1;
  // ... as long as at most this share of the box's target pixels has no expectation.
  double range_unknown_share = 0.1;
  // A box wider than twice this (the rolling refresh's band spans the image) is split into
  // pieces about this wide when their narrowed ranges, padding included, cost less than the
  // whole box's range: the band's range is that of everything across the image, a piece's only
  // that of what lies in it. 0 = never split.
  int split_width_px = 160;

  void Validate() const;  // std::invalid_argument with the reason
};

// One SGBM call: the padded box it runs on and the box of the mask pixels it answers for.
struct RoiBox {
  cv::Rect padded;
  cv::Rect target;
};

struct RoiStereoStats {
  int boxes = 0;
  int narrowed_boxes = 0;       // boxes searched over a narrowed range
  long long target_pixels = 0;  // pixels of the mask (given fresh values)
  // Pixels SGBM processed (the padded boxes), weighted by their share of the full search range:
  // the cost in full-frame pixels.
  long long computed_pixels = 0;
  std::vector<RoiBox> plan;
};

// Not thread-safe (OpenCV keeps work buffers in the matcher): one per pipeline.
class RoiStereo {
 public:
  explicit RoiStereo(const stereo::SgbmParams& sgbm, const RoiStereoParams& params = {});

  // Full-frame disparity (CV_32F, NaN = no match), the same matcher as the regions use.
  cv::Mat ComputeFull(const cv::Mat& left, const cv::Mat& right);

  // Recomputes the pixels where `mask` (CV_8U) is non-zero and writes them (NaN where SGBM
  // finds no match) into `disparity` (CV_32F, the images' size); other pixels are untouched.
  // `expected` (optional, CV_32F, NaN = unknown) narrows each box's search range when (nearly)
  // all its target pixels have an expectation ("over the disparity range it needs"); other
  // boxes search the full range.
  // `expected_unknown` (optional, CV_8U): non-zero where `expected` is to be treated as unknown
  // (saves the caller a masked copy of `expected`).
  RoiStereoStats ComputeMasked(const cv::Mat& left, const cv::Mat& right, const cv::Mat& mask,
                               cv::Mat& disparity, const cv::Mat& expected = cv::Mat(),
                               const cv::Mat& expected_unknown = cv::Mat());

  // The padded boxes SGBM would run on for `mask` (exposed for tests and the benchmark).
  std::vector<RoiBox> PlanBoxes(const cv::Mat& mask) const;

  const stereo::SgbmParams& sgbm() const { return sgbm_; }
  // SGBM's blind margins, on the full frame as in any box. Columns left of the first never get
  // a value (no room for the search range); columns right of the last get values that are
  // mostly wrong or missing (the block does not fit: measured on the head scenario, 58% of the
  // last column off by more than 2 px, 31% missing). Recomputing them is pointless, and a map
  // that kept their values would carry the errors inward as the camera turns.
  int first_matchable_column() const {
    return std::max(sgbm_.min_disparity + sgbm_.num_disparities, 0);
  }
  int last_matchable_column(int width) const { return width - 1 - sgbm_.block_size / 2; }

 private:
  // SGBM over [min_disparity, min_disparity + num_disparities), NaN where no match.
  cv::Mat Match(const cv::Mat& left, const cv::Mat& right, int min_disparity, int num_disparities);
  stereo::SgbmParams sgbm_;
  RoiStereoParams params_;
  cv::Ptr<cv::StereoSGBM> matcher_;
};

}  // namespace epmap::ep
