#include "perception/localisation/stereo_features.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <stdexcept>
#include <string>

namespace epmap::localisation {

void StereoFeatureParams::Validate() const {
  if (max_features < 1) throw std::invalid_argument("features: max_features must be >= 1");
  if (!(quality_level > 0 && quality_level < 1)) {
    throw std::invalid_argument("features: quality_level must be in (0, 1)");
  }
  if (lk_window_px < 5 || lk_window_px % 2 == 0) {
    throw std::invalid_argument("features: lk_window_px must be odd and >= 5");
  }
  if (lk_levels < 0) throw std::invalid_argument("features: lk_levels must be >= 0");
  if (coarse_scale < 1) throw std::invalid_argument("features: coarse_scale must be >= 1");
  if (coarse_num_disparities < 16 || coarse_num_disparities % 16 != 0) {
    throw std::invalid_argument("features: coarse_num_disparities must be a multiple of 16");
  }
  if (!(disparity_sigma_px > 0) || !(min_point_sigma_m > 0)) {
    throw std::invalid_argument("features: sigmas must be > 0");
  }
  if (!(min_disparity_px > 0) || !(max_range_m > 0)) {
    throw std::invalid_argument("features: min_disparity_px and max_range_m must be > 0");
  }
}

double DepthSigma(const stereo::RectifiedGeometry& c, double z, double sd, double min_sigma) {
  return std::max(min_sigma, z * z * sd / (c.fx * c.baseline_m));
}

namespace {

cv::Mat Grey(const cv::Mat& image) {
  if (image.empty()) throw std::invalid_argument("stereo features: empty image");
  cv::Mat g;
  if (image.channels() == 3) {
    cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, g, cv::COLOR_BGRA2GRAY);
  } else {
    g = image;
  }
  if (g.depth() != CV_8U) g.convertTo(g, CV_8U, g.depth() == CV_16U ? 1.0 / 256.0 : 1.0);
  return g;
}

}  // namespace

Eigen::Vector3d Backproject(const stereo::RectifiedGeometry& c, const cv::Point2f& l, double d) {
  const double z = c.fx * c.baseline_m / d;
  return {(l.x - c.cx) * z / c.fx, (l.y - c.cy) * z / c.fy, z};
}

StereoFeatureTracker::StereoFeatureTracker(const stereo::RectifiedGeometry& camera,
                                           const StereoFeatureParams& params)
    : camera_(camera), params_(params) {
  params_.Validate();
  if (!(camera.fx > 0) || !(camera.fy > 0) || !(camera.baseline_m > 0) || camera.width <= 0 ||
      camera.height <= 0) {
    throw std::invalid_argument(
        "stereo features: the camera needs a size, focal lengths and a "
        "baseline > 0");
  }
  stereo::SgbmParams sp;
  sp.num_disparities = params_.coarse_num_disparities;
  sp.block_size = 5;
  sp.p1 = 8 * 25;
  sp.p2 = 32 * 25;
  coarse_ = std::make_shared<stereo::SgbmMatcher>(sp);
}

KeyFrameFeatures StereoFeatureTracker::Detect(const cv::Mat& left_in, const cv::Mat& right_in,
                                              const Eigen::Isometry3d& T_base_cam) const {
  KeyFrameFeatures kf;
  kf.left = Grey(left_in);
  kf.right = Grey(right_in);
  kf.T_base_cam = T_base_cam;
  if (kf.left.size() != kf.right.size()) {
    throw std::invalid_argument("stereo features: left and right differ in size");
  }
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(kf.left, corners, params_.max_features, params_.quality_level,
                          params_.min_distance_px, cv::noArray(), params_.block_size);
  if (corners.empty()) return kf;

  // Coarse disparity at lower resolution seeds the left/right Lucas-Kanade match (Sec. 3.1).
  const double s = params_.coarse_scale;
  // SGBM leaves the left num_disparities columns unmatched; padding both images on the left
  // by that much lets features near the left border get a seed too.
  cv::Mat sl, sr;
  cv::resize(kf.left, sl, cv::Size(), 1.0 / s, 1.0 / s, cv::INTER_AREA);
  cv::resize(kf.right, sr, cv::Size(), 1.0 / s, 1.0 / s, cv::INTER_AREA);
  const int pad = params_.coarse_num_disparities;
  cv::copyMakeBorder(sl, sl, 0, 0, pad, 0, cv::BORDER_REPLICATE);
  cv::copyMakeBorder(sr, sr, 0, 0, pad, 0, cv::BORDER_REPLICATE);
  const cv::Mat coarse = coarse_->Compute(sl, sr)(cv::Rect(pad, 0, sl.cols - pad, sl.rows));
  std::vector<cv::Point2f> left, guess;
  for (const auto& p : corners) {
    const int cx = std::clamp(static_cast<int>(p.x / s), 0, coarse.cols - 1);
    const int cy = std::clamp(static_cast<int>(p.y / s), 0, coarse.rows - 1);
    const float d = coarse.at<float>(cy, cx);
    if (!std::isfinite(d)) continue;
    left.push_back(p);
    guess.emplace_back(p.x - d * static_cast<float>(s), p.y);
  }
  if (left.empty()) return kf;
  const cv::Size win(params_.lk_window_px, params_.lk_window_px);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  std::vector<uchar> ok, ok_back;
  std::vector<float> err;
  std::vector<cv::Point2f> right = guess;
  cv::calcOpticalFlowPyrLK(kf.left, kf.right, left, right, ok, err, win, 1, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  std::vector<cv::Point2f> back = left;
  cv::calcOpticalFlowPyrLK(kf.right, kf.left, right, back, ok_back, err, win, 1, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  for (size_t i = 0; i < left.size(); ++i) {
    if (!ok[i] || !ok_back[i]) continue;
    if (cv::norm(back[i] - left[i]) > params_.max_forward_backward_px) continue;
    if (std::abs(right[i].y - left[i].y) > params_.max_row_error_px) continue;
    const double d = left[i].x - right[i].x;
    if (d < params_.min_disparity_px) continue;
    const Eigen::Vector3d p = Backproject(camera_, left[i], d);
    if (p.norm() > params_.max_range_m) continue;
    kf.features.push_back({left[i], right[i], p});
  }
  return kf;
}

TrackedPairs StereoFeatureTracker::Track(const KeyFrameFeatures& prev, const KeyFrameFeatures& cur,
                                         const Eigen::Isometry3d& T_cur_prev) const {
  TrackedPairs out;
  if (prev.features.empty() || cur.left.empty()) return out;
  if (prev.left.size() != cur.left.size()) {
    throw std::invalid_argument("stereo features: key frames differ in image size");
  }
  // Prediction: the feature's 3-D point carried through the motion into the new camera.
  const Eigen::Isometry3d T_curcam_prevcam =
      cur.T_base_cam.inverse() * T_cur_prev * prev.T_base_cam;
  std::vector<size_t> index;
  std::vector<cv::Point2f> pl, pr, ql, qr;
  const float border = static_cast<float>(params_.border_px);
  const float w = static_cast<float>(camera_.width) - border;
  const float h = static_cast<float>(camera_.height) - border;
  for (size_t i = 0; i < prev.features.size(); ++i) {
    const Eigen::Vector3d q = T_curcam_prevcam * prev.features[i].p_cam;
    if (q.z() < 0.1) continue;
    const double ul = camera_.fx * q.x() / q.z() + camera_.cx;
    const double v = camera_.fy * q.y() / q.z() + camera_.cy;
    const double d = camera_.fx * camera_.baseline_m / q.z();
    const cv::Point2f l(static_cast<float>(ul), static_cast<float>(v));
    const cv::Point2f r(static_cast<float>(ul - d), static_cast<float>(v));
    if (l.x < border || l.y < border || l.x > w || l.y > h || r.x < border || r.x > w) continue;
    index.push_back(i);
    pl.push_back(prev.features[i].left);
    pr.push_back(prev.features[i].right);
    ql.push_back(l);
    qr.push_back(r);
  }
  out.predicted = index.size();
  if (index.empty()) return out;
  const cv::Size win(params_.lk_window_px, params_.lk_window_px);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  const auto track = [&](const cv::Mat& a, const cv::Mat& b, const std::vector<cv::Point2f>& from,
                         std::vector<cv::Point2f>& to, std::vector<bool>& good) {
    std::vector<uchar> ok, ok_back;
    std::vector<float> err;
    cv::calcOpticalFlowPyrLK(a, b, from, to, ok, err, win, params_.lk_levels, term,
                             cv::OPTFLOW_USE_INITIAL_FLOW);
    std::vector<cv::Point2f> back = from;
    cv::calcOpticalFlowPyrLK(b, a, to, back, ok_back, err, win, params_.lk_levels, term,
                             cv::OPTFLOW_USE_INITIAL_FLOW);
    good.assign(from.size(), false);
    for (size_t k = 0; k < from.size(); ++k) {
      good[k] =
          ok[k] && ok_back[k] && cv::norm(back[k] - from[k]) <= params_.max_forward_backward_px;
    }
  };
  std::vector<bool> good_l, good_r;
  track(prev.left, cur.left, pl, ql, good_l);
  track(prev.right, cur.right, pr, qr, good_r);
  for (size_t k = 0; k < index.size(); ++k) {
    if (!good_l[k]) continue;
    ++out.tracked_left;
    if (!good_r[k]) continue;
    if (std::abs(qr[k].y - ql[k].y) > params_.max_row_error_px) continue;
    const double d = ql[k].x - qr[k].x;
    if (d < params_.min_disparity_px) continue;
    const Eigen::Vector3d p_cur = Backproject(camera_, ql[k], d);
    if (p_cur.norm() > params_.max_range_m) continue;
    ++out.tracked_stereo;
    const Eigen::Vector3d& p_prev = prev.features[index[k]].p_cam;
    out.x_prev.push_back(prev.T_base_cam * p_prev);
    out.x_cur.push_back(cur.T_base_cam * p_cur);
    const double z = std::max(p_prev.z(), p_cur.z());
    out.sigma.push_back(
        DepthSigma(camera_, z, params_.disparity_sigma_px, params_.min_point_sigma_m));
  }
  return out;
}

}  // namespace epmap::localisation
