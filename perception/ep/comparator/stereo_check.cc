#include "perception/ep/comparator/stereo_check.h"

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "perception/ep/comparator/visual_comparator.h"

namespace epmap::ep {

void StereoCheckParams::Validate() const {
  if (!(threshold_grey > 0)) throw std::invalid_argument("stereo check: threshold must be > 0");
  if (window_px < 1 || window_px % 2 == 0) {
    throw std::invalid_argument("stereo check: window_px must be odd and >= 1");
  }
  if (open_radius_px < 0 || min_region_area_px < 0) {
    throw std::invalid_argument("stereo check: open radius and minimum area must be >= 0");
  }
}

StereoCheck CheckStereo(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity,
                        const StereoCheckParams& params) {
  params.Validate();
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size() ||
      disparity.type() != CV_32FC1 || disparity.size() != left.size()) {
    throw std::invalid_argument("stereo check: CV_8U pair and CV_32F disparity of one size");
  }
  const int W = left.cols, H = left.rows;
  cv::Mat map_x(H, W, CV_32F), map_y(H, W, CV_32F), valid(H, W, CV_8U);
  for (int v = 0; v < H; ++v) {
    const float* d = disparity.ptr<float>(v);
    float* mx = map_x.ptr<float>(v);
    float* my = map_y.ptr<float>(v);
    uint8_t* ok = valid.ptr<uint8_t>(v);
    for (int u = 0; u < W; ++u) {
      const float x = static_cast<float>(u) - d[u];
      ok[u] = (x >= 0.0F && x <= static_cast<float>(W - 1)) ? 255 : 0;  // false for NaN
      mx[u] = ok[u] ? x : -1.0F;
      my[u] = static_cast<float>(v);
    }
  }
  cv::Mat right_f, warped;
  right.convertTo(right_f, CV_32F);
  cv::remap(right_f, warped, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  const auto [gain, offset] = FitGainOffset(warped, valid, left);
  warped.convertTo(warped, CV_32F, gain, offset);
  cv::Mat left_f, diff;
  left.convertTo(left_f, CV_32F);
  cv::absdiff(left_f, warped, diff);
  diff.setTo(0, valid == 0);
  // Mean over the window's valid pixels only (unknown neighbours must not count as errors).
  cv::Mat weight;
  valid.convertTo(weight, CV_32F, 1.0 / 255.0);
  const cv::Size window(params.window_px, params.window_px);
  cv::boxFilter(diff, diff, -1, window, cv::Point(-1, -1), false);
  cv::boxFilter(weight, weight, -1, window, cv::Point(-1, -1), false);
  StereoCheck out;
  cv::divide(diff, weight, out.residual);
  out.residual.setTo(std::numeric_limits<float>::quiet_NaN(), valid == 0);
  out.inconsistent = RemoveSpecks(out.residual > params.threshold_grey, params.open_radius_px,
                                  params.min_region_area_px);  // NaN compares false
  return out;
}

}  // namespace epmap::ep
