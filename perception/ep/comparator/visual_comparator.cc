#include "perception/ep/comparator/visual_comparator.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "common/cpu/hot_loop.h"

namespace epmap::ep {

namespace {

struct CompareRowConstants {
  float gain, offset, threshold;
  float e_new, c_new, e_unexpected, c_unexpected;  // C's weights, without and with a flag
};
struct RowSums {
  double error = 0, attenuated = 0;
  int valid = 0;
};

// One row of E, A, C and the pixels above the threshold (see Compare); `att` holds
// exp(-alpha C_-^2). The images in a loop the compiler vectorises (no sums in it), then the
// sums in eight independent lanes (one running sum made every pixel wait for the previous
// addition).
EPMAP_HOT_LOOP RowSums CompareRow(const CompareRowConstants& k, int width,
                                  const float* __restrict pred, const float* __restrict hist,
                                  const float* __restrict att, const uint8_t* __restrict ok,
                                  const uint8_t* __restrict seen, float* __restrict e_row,
                                  float* __restrict a_row, float* __restrict c_row,
                                  uint8_t* __restrict up) {
  for (int u = 0; u < width; ++u) {
    // Choices as multiplications by 0 or 1 (exact: x * 1 = x, x * 0 + y = y for finite x, y):
    // GCC does not turn a choice made on a byte into a vector select, and leaves such a loop
    // scalar.
    const float valid = ok[u] != 0 ? 1.0F : 0.0F;
    const float e = valid * std::abs(pred[u] * k.gain + k.offset - static_cast<float>(seen[u]));
    const float a = e * att[u];
    const float flag = a > k.threshold ? 1.0F : 0.0F;
    e_row[u] = e;  // 0 where invalid
    a_row[u] = a;
    up[u] = static_cast<uint8_t>(flag * 255.0F);
    const float c_flagged = e * k.e_unexpected + hist[u] * k.c_unexpected;
    const float c_plain = e * k.e_new + hist[u] * k.c_new;
    c_row[u] = valid * (flag * c_flagged + (1.0F - flag) * c_plain);
  }
  constexpr int kLanes = 8;
  float error_lanes[kLanes] = {}, attenuated_lanes[kLanes] = {};
  int valid_lanes[kLanes] = {};
  int u = 0;
  for (; u + kLanes <= width; u += kLanes) {
    for (int lane = 0; lane < kLanes; ++lane) {
      error_lanes[lane] += e_row[u + lane];
      attenuated_lanes[lane] += a_row[u + lane];
      valid_lanes[lane] += ok[u + lane] != 0 ? 1 : 0;
    }
  }
  RowSums sums;
  for (; u < width; ++u) {
    sums.error += e_row[u];
    sums.attenuated += a_row[u];
    sums.valid += ok[u] != 0 ? 1 : 0;
  }
  for (int lane = 0; lane < kLanes; ++lane) {
    sums.error += error_lanes[lane];
    sums.attenuated += attenuated_lanes[lane];
    sums.valid += valid_lanes[lane];
  }
  return sums;
}

}  // namespace

void ComparatorParams::Validate() const {
  if (!(lambda >= 0)) throw std::invalid_argument("comparator: lambda must be >= 0");
  if (!(alpha >= 0)) throw std::invalid_argument("comparator: alpha must be >= 0");
  if (!(threshold_grey > 0)) throw std::invalid_argument("comparator: threshold must be > 0");
  if (!(unexpected_weight >= 0 && unexpected_weight <= 1)) {
    throw std::invalid_argument("comparator: unexpected_weight must be in [0, 1]");
  }
  if (!(grow_threshold_grey >= 0)) {
    throw std::invalid_argument("comparator: grow_threshold_grey must be >= 0 (0 = off)");
  }
  if (open_radius_px < 0 || close_radius_px < 0 || min_region_area_px < 0) {
    throw std::invalid_argument("comparator: radii and minimum area must be >= 0");
  }
}

std::pair<double, double> FitGainOffset(const cv::Mat& predicted, const cv::Mat& valid,
                                        const cv::Mat& actual) {
  constexpr int kStep = 4;
  std::vector<float> p, a;
  p.reserve(static_cast<size_t>(predicted.total() / (kStep * kStep)));
  a.reserve(p.capacity());
  for (int v = 0; v < predicted.rows; v += kStep) {
    const float* pr = predicted.ptr<float>(v);
    const uint8_t* va = valid.ptr<uint8_t>(v);
    const uint8_t* ac = actual.ptr<uint8_t>(v);
    for (int u = 0; u < predicted.cols; u += kStep) {
      // Saturated pixels carry no exposure information.
      if (va[u] && ac[u] > 2 && ac[u] < 253) {
        p.push_back(pr[u]);
        a.push_back(ac[u]);
      }
    }
  }
  double gain = 1, offset = 0;
  double max_residual = 1e30;
  for (int pass = 0; pass < 2; ++pass) {
    double n = 0, sp = 0, sa = 0, spp = 0, spa = 0;
    for (size_t i = 0; i < p.size(); ++i) {
      if (std::abs(a[i] - (gain * p[i] + offset)) > max_residual) continue;
      n += 1;
      sp += p[i];
      sa += a[i];
      spp += static_cast<double>(p[i]) * p[i];
      spa += static_cast<double>(p[i]) * a[i];
    }
    const double det = n * spp - sp * sp;
    if (n < 100 || det <= 1e-9 * n * n) return {1.0, 0.0};
    const double g = (n * spa - sp * sa) / det;
    const double o = (sa - g * sp) / n;
    if (!(g > 0.5 && g < 2.0) || !(std::abs(o) < 64.0)) return {1.0, 0.0};
    gain = g;
    offset = o;
    double r2 = 0;
    for (size_t i = 0; i < p.size(); ++i) r2 += std::pow(a[i] - (gain * p[i] + offset), 2);
    max_residual = std::max(3.0 * std::sqrt(r2 / static_cast<double>(p.size())), 4.0);
  }
  return {gain, offset};
}

cv::Mat GrowFromSeeds(const cv::Mat& seeds, const cv::Mat& candidates) {
  CV_Assert(seeds.type() == CV_8UC1 && candidates.type() == CV_8UC1 &&
            seeds.size() == candidates.size());
  cv::Mat out = cv::Mat::zeros(seeds.size(), CV_8U);
  std::vector<cv::Point> stack;
  for (int v = 0; v < seeds.rows; ++v) {
    const uint8_t* s = seeds.ptr<uint8_t>(v);
    uint8_t* o = out.ptr<uint8_t>(v);
    for (int u = 0; u < seeds.cols; ++u) {
      if (s[u] && !o[u]) {
        o[u] = 255;
        stack.emplace_back(u, v);
      }
    }
  }
  while (!stack.empty()) {
    const cv::Point p = stack.back();
    stack.pop_back();
    for (int dv = -1; dv <= 1; ++dv) {
      const int v = p.y + dv;
      if (v < 0 || v >= out.rows) continue;
      const uint8_t* c = candidates.ptr<uint8_t>(v);
      uint8_t* o = out.ptr<uint8_t>(v);
      for (int du = -1; du <= 1; ++du) {
        const int u = p.x + du;
        if (u < 0 || u >= out.cols || o[u] || !c[u]) continue;
        o[u] = 255;
        stack.emplace_back(u, v);
      }
    }
  }
  return out;
}

cv::Mat RemoveSpecks(const cv::Mat& mask, int open_radius_px, int min_area_px,
                     int close_radius_px) {
  cv::Mat out;
  if (open_radius_px > 0) {
    const cv::Mat k = cv::getStructuringElement(
        cv::MORPH_RECT, cv::Size(2 * open_radius_px + 1, 2 * open_radius_px + 1));
    cv::morphologyEx(mask, out, cv::MORPH_OPEN, k);
  } else {
    out = mask.clone();
  }
  // Closing and labelling only inside the box of what is left, grown by what the closing can
  // reach (all else is 0 before and after): usually a small part of the image. Nothing left
  // (most frames): nothing to do.
  const cv::Rect left_box = cv::boundingRect(out);
  if (left_box.empty()) return out;
  const int reach = 2 * std::max(close_radius_px, 0) + 1;
  const cv::Rect roi = cv::Rect(left_box.x - reach, left_box.y - reach, left_box.width + 2 * reach,
                                left_box.height + 2 * reach) &
                       cv::Rect(0, 0, out.cols, out.rows);
  cv::Mat part = out(roi);
  if (close_radius_px > 0) {
    const cv::Mat k = cv::getStructuringElement(
        cv::MORPH_RECT, cv::Size(2 * close_radius_px + 1, 2 * close_radius_px + 1));
    // BORDER_ISOLATED: the part is closed as an image of its own (outside it all is 0 anyway).
    cv::Mat closed;
    cv::morphologyEx(part, closed, cv::MORPH_CLOSE, k, cv::Point(-1, -1), 1,
                     cv::BORDER_CONSTANT | cv::BORDER_ISOLATED);
    closed.copyTo(part);
  }
  if (min_area_px > 1) {
    cv::Mat labels, stats, centroids;
    const int n = cv::connectedComponentsWithStats(part, labels, stats, centroids, 8, CV_32S);
    std::vector<uint8_t> keep(static_cast<size_t>(n), 0);
    bool any_dropped = false;
    for (int i = 1; i < n; ++i) {
      keep[static_cast<size_t>(i)] = stats.at<int>(i, cv::CC_STAT_AREA) >= min_area_px ? 255 : 0;
      any_dropped |= keep[static_cast<size_t>(i)] == 0;
    }
    if (any_dropped) {
      for (int v = 0; v < part.rows; ++v) {
        const int* l = labels.ptr<int>(v);
        uint8_t* o = part.ptr<uint8_t>(v);
        for (int u = 0; u < part.cols; ++u) o[u] = keep[static_cast<size_t>(l[u])];
      }
    }
  }
  return out;
}

Comparison Compare(const cv::Mat& predicted, const cv::Mat& valid,
                   const cv::Mat& predicted_accumulated, const cv::Mat& actual,
                   const ComparatorParams& params, const PredictionHints& hints) {
  params.Validate();
  const cv::Size size = actual.size();
  if (actual.type() != CV_8UC1) throw std::invalid_argument("comparator: L must be CV_8UC1");
  if (predicted.type() != CV_32FC1 || predicted.size() != size ||
      predicted_accumulated.type() != CV_32FC1 || predicted_accumulated.size() != size ||
      valid.type() != CV_8UC1 || valid.size() != size) {
    throw std::invalid_argument("comparator: L_-, C_- (CV_32F) and valid (CV_8U) must match L");
  }
  for (const cv::Mat* hint : {&hints.moved_before, &hints.guessed}) {
    if (!hint->empty() && (hint->type() != CV_8UC1 || hint->size() != size)) {
      throw std::invalid_argument("comparator: the prediction hints (CV_8U) must match L");
    }
  }
  const cv::Mat& moved_before = hints.moved_before;
  Comparison out;
  if (params.compensate_exposure) {
    std::tie(out.gain, out.offset) = FitGainOffset(predicted, valid, actual);
  }
  out.error.create(size, CV_32F);
  out.attenuated.create(size, CV_32F);
  out.accumulated.create(size, CV_32F);
  cv::Mat above(size, CV_8U);
  // One pass for the rest, rows shared by two threads:
  //   E = |L_- - L| (Sec. IV-A), only where the prediction exists (0 elsewhere);
  //   A = E exp(-alpha (C_-)^2) (Sec. IV-A), with the propagated history C_- (the exponential
  //   by OpenCV's vectorised exp, a row at a time);
  //   unexpected: A above the threshold (Sec. IV-A), specks removed below;
  //   C = (E + lambda C_-) / (lambda + 1) (Sec. IV-A); no history where nothing was predicted.
  //   Every pixel above the threshold (specks included: a speck removed from the output is
  //   still an unexpected error, not predictable noise) feeds its error with the weight w
  //   instead: C = (w E + lambda C_-) / (w + lambda) (w = 1: the paper).
  const float gain = static_cast<float>(out.gain), offset = static_cast<float>(out.offset);
  const float threshold = static_cast<float>(params.threshold_grey);
  const float minus_alpha = static_cast<float>(-params.alpha);
  const double lambda = params.lambda, w = std::min(params.unexpected_weight, 1.0);
  const float e_new = static_cast<float>(1.0 / (lambda + 1.0));
  const float c_new = static_cast<float>(lambda / (lambda + 1.0));
  const float e_unexpected = static_cast<float>(w / (w + lambda));
  const float c_unexpected = static_cast<float>(lambda / (w + lambda));
  // Per-row sums, added in row order afterwards (the same total whatever the threads did).
  std::vector<double> row_errors(static_cast<size_t>(size.height)),
      row_attenuated_sums(row_errors.size());
  std::vector<int> row_valid_counts(row_errors.size());
  const CompareRowConstants k{gain, offset, threshold, e_new, c_new, e_unexpected, c_unexpected};
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    cv::Mat attenuation(1, size.width, CV_32F);
    for (int v = rows.start; v < rows.end; ++v) {
      const float* hist = predicted_accumulated.ptr<float>(v);
      float* att = attenuation.ptr<float>(0);
      for (int u = 0; u < size.width; ++u) att[u] = minus_alpha * hist[u] * hist[u];
      cv::exp(attenuation, attenuation);
      const RowSums sums =
          CompareRow(k, size.width, predicted.ptr<float>(v), hist, att, valid.ptr<uint8_t>(v),
                     actual.ptr<uint8_t>(v), out.error.ptr<float>(v), out.attenuated.ptr<float>(v),
                     out.accumulated.ptr<float>(v), above.ptr<uint8_t>(v));
      row_errors[static_cast<size_t>(v)] = sums.error;
      row_attenuated_sums[static_cast<size_t>(v)] = sums.attenuated;
      row_valid_counts[static_cast<size_t>(v)] = sums.valid;
    }
  });
  double sum_error = 0, sum_attenuated = 0;
  for (size_t v = 0; v < row_errors.size(); ++v) {
    sum_error += row_errors[v];
    sum_attenuated += row_attenuated_sums[v];
    out.valid_pixels += row_valid_counts[v];
  }
  // Growth (see grow_threshold_grey). Candidates: a large error that its history attenuated
  // to the threshold or below, where the depth is not a guess. Seeds: what is flagged without
  // growth, and the candidates that moved on their own last frame, cleaned alike; grown through the
  // candidates, closed again.
  const bool grow = params.grow_threshold_grey > 0;
  cv::Mat candidates;
  const auto find_candidates = [&] {
    cv::Mat attenuated_below;
    cv::compare(out.error, params.grow_threshold_grey, candidates, cv::CMP_GT);
    cv::compare(out.attenuated, params.threshold_grey, attenuated_below, cv::CMP_LE);
    candidates &= attenuated_below;
    if (!hints.guessed.empty()) candidates.setTo(0, hints.guessed);
  };
  if (grow && !moved_before.empty() && cv::countNonZero(moved_before) > 0) {
    find_candidates();
    cv::Mat still_moving;
    cv::bitwise_and(moved_before, candidates, still_moving);
    above |= still_moving;  // what moved last frame and is still a candidate seeds too
  }
  out.flagged =
      RemoveSpecks(above, params.open_radius_px, params.min_region_area_px, params.close_radius_px);
  if (grow && cv::countNonZero(out.flagged) > 0) {  // most frames: nothing to grow
    if (candidates.empty()) find_candidates();
    out.flagged =
        RemoveSpecks(GrowFromSeeds(out.flagged, candidates), 0, 0, params.close_radius_px);
  }
  if (out.valid_pixels > 0) {
    out.mean_error = sum_error / out.valid_pixels;
    out.mean_attenuated = sum_attenuated / out.valid_pixels;
  }
  return out;
}

}  // namespace epmap::ep
