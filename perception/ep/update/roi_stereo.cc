#include "perception/ep/update/roi_stereo.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "common/cpu/hot_loop.h"

namespace epmap::ep {

namespace {

// SGBM's fixed-point disparities (CV_16S, 1/16 px) as float pixels, NaN where it found no
// match ("no match" is (min_disparity - 1) * 16).
EPMAP_HOT_LOOP void FixedToFloat(const cv::Mat& fixed, int min_disparity, cv::Mat* out) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int invalid_below = min_disparity * 16;
  for (int r = 0; r < fixed.rows; ++r) {
    const int16_t* __restrict in = fixed.ptr<int16_t>(r);
    float* __restrict o = out->ptr<float>(r);
    for (int c = 0; c < fixed.cols; ++c) {
      o[c] = in[c] < invalid_below ? nan : static_cast<float>(in[c]) * (1.0F / 16.0F);
    }
  }
}

}  // namespace

void RoiStereoParams::Validate() const {
  if (context_px < 0) throw std::invalid_argument("ROI stereo: context_px must be >= 0");
  if (!(merge_slack >= 1.0)) throw std::invalid_argument("ROI stereo: merge_slack must be >= 1");
  if (band_rows < 1) throw std::invalid_argument("ROI stereo: band_rows must be >= 1");
  if (split_width_px < 0) throw std::invalid_argument("ROI stereo: split_width_px must be >= 0");
}

RoiStereo::RoiStereo(const stereo::SgbmParams& sgbm, const RoiStereoParams& params)
    : sgbm_(sgbm), params_(params) {
  sgbm_.Validate();
  params_.Validate();
  matcher_ = cv::StereoSGBM::create(sgbm.min_disparity, sgbm.num_disparities, sgbm.block_size,
                                    sgbm.p1, sgbm.p2, sgbm.disp12_max_diff, sgbm.pre_filter_cap,
                                    sgbm.uniqueness_ratio, sgbm.speckle_window, sgbm.speckle_range,
                                    sgbm.mode);
}

cv::Mat RoiStereo::Match(const cv::Mat& left, const cv::Mat& right, int min_disparity,
                         int num_disparities) {
  matcher_->setMinDisparity(min_disparity);
  matcher_->setNumDisparities(num_disparities);
  cv::Mat fixed;
  matcher_->compute(left, right, fixed);  // CV_16S, disparity * 16
  cv::Mat out(fixed.size(), CV_32FC1);
  FixedToFloat(fixed, min_disparity, &out);
  return out;
}

cv::Mat RoiStereo::ComputeFull(const cv::Mat& left, const cv::Mat& right) {
  if (left.size() != right.size() || left.type() != right.type()) {
    throw std::invalid_argument("ROI stereo: left and right differ in size or type");
  }
  return Match(left, right, sgbm_.min_disparity, sgbm_.num_disparities);
}

std::vector<RoiBox> RoiStereo::PlanBoxes(const cv::Mat& mask) const {
  const int half = sgbm_.block_size / 2 + params_.context_px;
  const int search = std::max(sgbm_.min_disparity + sgbm_.num_disparities, 0);
  const cv::Rect image(0, 0, mask.cols, mask.rows);
  const auto pad = [&](const cv::Rect& t) {
    return cv::Rect(t.x - half - search, t.y - half, t.width + 2 * half + search,
                    t.height + 2 * half) &
           image;
  };
  // Tight boxes of each band's connected pieces. The bands are labelled on two threads, each
  // band by one (OpenCV's labelling, called inside a parallel region, does not dispatch threads
  // of its own: for a band of a few rows that dispatch cost more than the labelling).
  const int n_bands = (mask.rows + params_.band_rows - 1) / params_.band_rows;
  std::vector<std::vector<RoiBox>> band_boxes(static_cast<size_t>(n_bands));
  cv::parallel_for_(cv::Range(0, n_bands), [&](const cv::Range& range) {
    cv::Mat labels, stats, centroids;
    for (int b = range.start; b < range.end; ++b) {
      const int y0 = b * params_.band_rows;
      const cv::Rect band(0, y0, mask.cols, std::min(params_.band_rows, mask.rows - y0));
      if (cv::countNonZero(mask(band)) == 0) continue;  // most bands: labelling costs far more
      const int n =
          cv::connectedComponentsWithStats(mask(band), labels, stats, centroids, 8, CV_32S);
      for (int i = 1; i < n; ++i) {
        const cv::Rect target(
            stats.at<int>(i, cv::CC_STAT_LEFT), y0 + stats.at<int>(i, cv::CC_STAT_TOP),
            stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
        band_boxes[static_cast<size_t>(b)].push_back({pad(target), target});
      }
    }
  });
  std::vector<RoiBox> boxes;  // in band order, whatever thread labelled which band
  for (const auto& in_band : band_boxes) boxes.insert(boxes.end(), in_band.begin(), in_band.end());
  // Greedy merging while some pair costs no more together than apart.
  bool merged = true;
  while (merged) {
    merged = false;
    for (size_t a = 0; a < boxes.size(); ++a) {
      for (size_t b = a + 1; b < boxes.size();) {
        const cv::Rect target = boxes[a].target | boxes[b].target;
        const cv::Rect padded = pad(target);
        const double apart = static_cast<double>(boxes[a].padded.area()) + boxes[b].padded.area();
        if (padded.area() <= params_.merge_slack * apart) {
          boxes[a] = {padded, target};
          boxes.erase(boxes.begin() + static_cast<std::ptrdiff_t>(b));
          merged = true;
          b = a + 1;  // the grown box may now absorb earlier ones
        } else {
          ++b;
        }
      }
    }
  }
  return boxes;
}

RoiStereoStats RoiStereo::ComputeMasked(const cv::Mat& left, const cv::Mat& right,
                                        const cv::Mat& mask, cv::Mat& disparity,
                                        const cv::Mat& expected, const cv::Mat& expected_unknown) {
  if (left.size() != right.size() || left.type() != right.type()) {
    throw std::invalid_argument("ROI stereo: left and right differ in size or type");
  }
  if (mask.type() != CV_8UC1 || mask.size() != left.size() || disparity.type() != CV_32FC1 ||
      disparity.size() != left.size()) {
    throw std::invalid_argument("ROI stereo: mask (CV_8U) and disparity (CV_32F) must match");
  }
  if (!expected.empty() && (expected.type() != CV_32FC1 || expected.size() != left.size())) {
    throw std::invalid_argument(
        "ROI stereo: expected disparity must be CV_32F of the images' size");
  }
  if (!expected_unknown.empty() &&
      (expected_unknown.type() != CV_8UC1 || expected_unknown.size() != left.size())) {
    throw std::invalid_argument("ROI stereo: expected_unknown must be CV_8U of the images' size");
  }
  RoiStereoStats stats;
  stats.plan = PlanBoxes(mask);
  stats.boxes = static_cast<int>(stats.plan.size());
  stats.target_pixels = cv::countNonZero(mask);
  const int full_min = sgbm_.min_disparity, full_num = sgbm_.num_disparities;
  const int half = sgbm_.block_size / 2 + params_.context_px;
  struct Search {
    int min_d, num_d;
    bool narrowed;
  };
  // The range the target's mask pixels need, if (nearly) all of them have an expectation.
  const auto search_for = [&](const cv::Rect& target) {
    Search s{full_min, full_num, false};
    if (expected.empty()) return s;
    float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
    long long with = 0, without = 0;
    for (int v = target.y; v < target.y + target.height; ++v) {
      const uint8_t* m = mask.ptr<uint8_t>(v);
      const float* e = expected.ptr<float>(v);
      const uint8_t* unknown =
          expected_unknown.empty() ? nullptr : expected_unknown.ptr<uint8_t>(v);
      for (int u = target.x; u < target.x + target.width; ++u) {
        if (!m[u]) continue;
        if (!std::isfinite(e[u]) || (unknown && unknown[u])) {
          ++without;
          continue;
        }
        ++with;
        lo = std::min(lo, e[u]);
        hi = std::max(hi, e[u]);
      }
    }
    const bool known =
        with > 0 && static_cast<double>(without) <=
                        params_.range_unknown_share * static_cast<double>(with + without);
    if (known && hi >= lo) {
      const double margin = params_.range_margin_px + params_.range_margin_share * hi;
      const int lo_d = std::max(full_min, static_cast<int>(std::floor(lo - margin)));
      const int hi_d = static_cast<int>(std::ceil(hi + margin));
      const int num = (hi_d - lo_d + 1 + 15) / 16 * 16;
      if (lo_d + num <= full_min + full_num && num < full_num) s = {lo_d, num, true};
    }
    return s;
  };
  // The box SGBM runs on for a target: `rows` (the planned padding's rows), and to the left only
  // this search's range.
  const int image_width = left.cols;
  const auto padded_for = [&](const cv::Rect& target, const cv::Rect& rows, const Search& s) {
    const int x0 = std::max(0, target.x - half - (s.min_d + s.num_d));
    const int x1 = std::min(image_width, target.x + target.width + half);
    return cv::Rect(x0, rows.y, x1 - x0, rows.height);
  };
  const auto cost = [&](const cv::Rect& padded, const Search& s) {
    return static_cast<long long>(padded.area()) * s.num_d;
  };
  for (const RoiBox& box : stats.plan) {
    const Search whole = search_for(box.target);
    std::vector<std::pair<cv::Rect, Search>> runs{{box.target, whole}};
    const int split = params_.split_width_px;
    if (split > 0 && !expected.empty() && box.target.width >= 2 * split) {
      const int n = (box.target.width + split / 2) / split;
      std::vector<std::pair<cv::Rect, Search>> pieces;
      long long pieces_cost = 0;
      for (int k = 0; k < n; ++k) {
        const int x0 = box.target.x + box.target.width * k / n;
        const int x1 = box.target.x + box.target.width * (k + 1) / n;
        const cv::Rect piece(x0, box.target.y, x1 - x0, box.target.height);
        const Search s = search_for(piece);
        pieces_cost += cost(padded_for(piece, box.padded, s), s);
        pieces.emplace_back(piece, s);
      }
      if (pieces_cost < cost(padded_for(box.target, box.padded, whole), whole)) runs = pieces;
    }
    for (const auto& [target, search] : runs) {
      const cv::Rect padded = padded_for(target, box.padded, search);
      if (search.narrowed) ++stats.narrowed_boxes;
      stats.computed_pixels += static_cast<long long>(padded.area()) * search.num_d / full_num;
      const cv::Mat fresh = Match(left(padded), right(padded), search.min_d, search.num_d);
      // Only the target's own mask pixels, which have the full padding around them.
      const cv::Rect in_box(target.x - padded.x, target.y - padded.y, target.width, target.height);
      fresh(in_box).copyTo(disparity(target), mask(target));
    }
  }
  return stats;
}

}  // namespace epmap::ep
