#include "perception/ep/expected_perception.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "perception/ep/generator/disparity_fill.h"

namespace epmap::ep {

namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

cv::Mat ToGrey(const cv::Mat& image, const char* which) {
  if (image.type() == CV_8UC1) return image;
  cv::Mat grey;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.type() == CV_8UC4) {
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  } else {
    throw std::invalid_argument(std::string("EP: the ") + which +
                                " image must be 8-bit grey, BGR or BGRA");
  }
  return grey;
}

void CheckPose(const Eigen::Isometry3d& T) {
  if (!T.matrix().allFinite()) throw std::invalid_argument("EP: T_base_cam0 is not finite");
  const Eigen::Matrix3d R = T.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
      std::abs(R.determinant() - 1.0) > 1e-6) {
    throw std::invalid_argument("EP: T_base_cam0's rotation is not orthonormal and right-handed");
  }
}

// Sets the columns outside [first, last] of `image` to `value`.
void BlindMargins(int first, int last, cv::Mat* image, double value) {
  const int w = image->cols;
  if (first > 0) (*image)(cv::Rect(0, 0, std::min(first, w), image->rows)).setTo(value);
  if (last + 1 < w) {
    const int x = std::max(last + 1, 0);
    (*image)(cv::Rect(x, 0, w - x, image->rows)).setTo(value);
  }
}

}  // namespace

const char* ToString(FrameMode mode) {
  switch (mode) {
    case FrameMode::kFirst:
      return "first";
    case FrameMode::kPredicted:
      return "predicted";
    case FrameMode::kRefreshScheduled:
      return "refresh_scheduled";
    case FrameMode::kRefreshShare:
      return "refresh_share";
    case FrameMode::kPoseJump:
      return "pose_jump";
  }
  return "unknown";
}

void EpParams::Validate() const {
  comparator.Validate();
  stereo_check.Validate();
  sgbm.Validate();
  roi.Validate();
  if (refresh.every_n_frames < 0) throw std::invalid_argument("EP: every_n_frames must be >= 0");
  if (!(refresh.max_recompute_share > 0)) {
    throw std::invalid_argument("EP: max_recompute_share must be > 0 (>= 1 disables it)");
  }
  if (!(max_rotation_step_rad > 0) || !(max_translation_step_m > 0)) {
    throw std::invalid_argument("EP: the pose jump bounds must be > 0");
  }
  if (recompute_margin_px < 0) throw std::invalid_argument("EP: recompute_margin_px must be >= 0");
  if (!(prediction.crack_max_step_px >= 0) || !(prediction.min_depth_m > 0) ||
      !(prediction.splat_radius_px >= 0.5 && prediction.splat_radius_px < 1.0)) {
    throw std::invalid_argument(
        "EP: crack_max_step_px >= 0, min_depth_m > 0 and splat_radius_px in [0.5, 1) expected");
  }
}

ExpectedPerception::ExpectedPerception(const stereo::RectifiedGeometry& camera,
                                       const EpParams& params)
    : camera_(camera), params_(params), stereo_(params.sgbm, params.roi) {
  if (camera.width <= 0 || camera.height <= 0 || !(camera.fx > 0) || !(camera.fy > 0) ||
      !(camera.baseline_m > 0) || !std::isfinite(camera.cx) || !std::isfinite(camera.cy)) {
    throw std::invalid_argument("EP: the camera needs a positive size, focal lengths and baseline");
  }
  params_.Validate();
}

void ExpectedPerception::Reset() {
  has_state_ = false;
  state_ = MapState{};
  frame_index_ = 0;
  frames_since_full_ = 0;
  refresh_requested_ = false;
}

std::shared_ptr<const EpResult> ExpectedPerception::Process(const cv::Mat& left_in,
                                                            const cv::Mat& right_in,
                                                            const Eigen::Isometry3d& T_base_cam0,
                                                            int64_t stamp_ns) {
  const auto t_start = Clock::now();
  // Validate everything before touching the state.
  const cv::Size size(camera_.width, camera_.height);
  if (left_in.size() != size || right_in.size() != size) {
    throw std::invalid_argument("EP: images must be " + std::to_string(size.width) + "x" +
                                std::to_string(size.height) + " (the camera's size)");
  }
  const cv::Mat left = ToGrey(left_in, "left");
  const cv::Mat right = ToGrey(right_in, "right");
  CheckPose(T_base_cam0);
  if (has_state_ && stamp_ns <= last_stamp_ns_) {
    throw std::invalid_argument("EP: stamp " + std::to_string(stamp_ns) +
                                " is not after the previous frame's " +
                                std::to_string(last_stamp_ns_));
  }

  const int first_column = stereo_.first_matchable_column();
  const int last_column = stereo_.last_matchable_column(size.width);
  auto res = std::make_shared<EpResult>();
  res->stamp_ns = stamp_ns;
  res->frame_index = frame_index_;
  res->T_base_cam0 = T_base_cam0;
  const double n_pixels = static_cast<double>(size.area());

  // 1-2. Predict and compare, unless there is nothing to predict from or the motion is not
  // trusted.
  FrameMode mode = FrameMode::kFirst;
  Prediction pred;
  Comparison cmp;
  if (has_state_) {
    const Eigen::Isometry3d T_cur_prev = T_base_cam0.inverse() * last_T_base_cam0_;
    const double angle = Eigen::AngleAxisd(T_cur_prev.linear()).angle();
    if (angle > params_.max_rotation_step_rad ||
        T_cur_prev.translation().norm() > params_.max_translation_step_m) {
      mode = FrameMode::kPoseJump;
    } else {
      mode = FrameMode::kPredicted;
      auto t0 = Clock::now();
      pred = Predict(state_, T_cur_prev, camera_, params_.prediction);
      res->timings.predict_ms = MsSince(t0);
      t0 = Clock::now();
      cmp = Compare(pred.image, pred.holes == 0, pred.accumulated, left, params_.comparator);
      if (params_.stereo_check.enabled) {
        res->stereo_inconsistent =
            CheckStereo(left, right, pred.disparity, params_.stereo_check).inconsistent;
      }
      res->timings.compare_ms = MsSince(t0);
      res->compared = true;
    }
  }

  // Plan what SGBM recomputes: unexpected regions grown by a margin, and holes.
  auto t0 = Clock::now();
  cv::Mat recompute;
  if (res->compared) {
    if (params_.recompute_margin_px > 0) {
      const int k = 2 * params_.recompute_margin_px + 1;
      cv::dilate(cmp.flagged, recompute, cv::getStructuringElement(cv::MORPH_RECT, {k, k}));
    } else {
      recompute = cmp.flagged.clone();
    }
    recompute |= pred.holes;
    if (!res->stereo_inconsistent.empty()) recompute |= res->stereo_inconsistent;
    if (params_.remeasure_dynamic) {
      // Where something moved on its own last frame, the map's geometry is not to be trusted:
      // re-measured whether or not E notices (the thing may have left a low-texture place).
      cv::Mat dynamic;
      cv::bitwise_and(pred.flags, cv::Scalar(kDynamic), dynamic);
      if (params_.recompute_margin_px > 0 && cv::countNonZero(dynamic) > 0) {
        const int k = 2 * params_.recompute_margin_px + 1;
        cv::dilate(dynamic, dynamic, cv::getStructuringElement(cv::MORPH_RECT, {k, k}));
      }
      recompute.setTo(255, dynamic);
    }
    // Pixels left unmeasured only because they lay in one of SGBM's blind margins are measured
    // once they come out of it ...
    for (int v = 0; v < size.height; ++v) {
      const uint8_t* flags = pred.flags.ptr<uint8_t>(v);
      const float* src_x = pred.source_x.ptr<float>(v);
      uint8_t* rec = recompute.ptr<uint8_t>(v);
      for (int u = first_column; u <= last_column; ++u) {
        if (!(flags[u] & kMeasured) && src_x[u] >= 0 &&
            (src_x[u] < static_cast<float>(first_column) ||
             src_x[u] > static_cast<float>(last_column))) {
          rec[u] = 255;
        }
      }
    }
    // ... and pixels still inside them are never worth a box: SGBM cannot match them.
    BlindMargins(first_column, last_column, &recompute, 0);
    const double share = cv::countNonZero(recompute) / n_pixels;
    const bool scheduled =
        refresh_requested_ ||
        (params_.refresh.every_n_frames > 0 &&
         frames_since_full_ + 1 >= static_cast<uint64_t>(params_.refresh.every_n_frames));
    if (scheduled) {
      mode = FrameMode::kRefreshScheduled;
    } else if (share > params_.refresh.max_recompute_share) {
      mode = FrameMode::kRefreshShare;
    }
  }
  res->timings.plan_ms = MsSince(t0);

  // 3. Disparity update: SGBM where needed (or everywhere), fused into the prediction.
  t0 = Clock::now();
  if (mode == FrameMode::kPredicted) {
    res->disparity = pred.disparity.clone();
    const RoiStereoStats stats = stereo_.ComputeMasked(left, right, recompute, res->disparity);
    res->recompute = recompute;
    res->recomputed_share = static_cast<double>(stats.target_pixels) / n_pixels;
    res->stereo_area_share = static_cast<double>(stats.computed_pixels) / n_pixels;
    res->sgbm_boxes = stats.boxes;
  } else {
    res->disparity = stereo_.ComputeFull(left, right);
    // SGBM's values in its blind margins are not kept (see RoiStereo::last_matchable_column);
    // on predicted frames the margins are never recomputed, so the map keeps what it had there.
    BlindMargins(first_column, last_column, &res->disparity,
                 std::numeric_limits<double>::quiet_NaN());
    res->recompute = cv::Mat(size, CV_8U, cv::Scalar(255));
    res->recomputed_share = 1.0;
    res->stereo_area_share = 1.0;
    res->sgbm_boxes = 1;
  }
  res->timings.stereo_ms = MsSince(t0);

  // The motion detector's output: flagged pixels, without those whose fresh disparity shows
  // the background a moving thing uncovered.
  t0 = Clock::now();
  if (res->compared) {
    res->unexpected = cmp.flagged.clone();
    if (params_.uncovered_margin_px > 0) {
      const float margin = static_cast<float>(params_.uncovered_margin_px);
      for (int v = 0; v < size.height; ++v) {
        uint8_t* u8 = res->unexpected.ptr<uint8_t>(v);
        const float* fresh = res->disparity.ptr<float>(v);
        const float* predicted = pred.geometry.ptr<float>(v);
        for (int u = 0; u < size.width; ++u) {
          if (u8[u] && fresh[u] < predicted[u] - margin) u8[u] = 0;  // false for NaN
        }
      }
      res->unexpected = RemoveSpecks(res->unexpected, 0, params_.comparator.min_region_area_px);
    }
    res->predicted_left = pred.image;
    res->error = cmp.error;
    res->attenuated = cmp.attenuated;
    res->accumulated = cmp.accumulated;
    res->holes = pred.holes;
    res->mean_error = cmp.mean_error;
    res->mean_attenuated = cmp.mean_attenuated;
    res->exposure_gain = cmp.gain;
    res->exposure_offset = cmp.offset;
    res->hole_share = cv::countNonZero(pred.holes) / n_pixels;
    res->non_finite_rejected = pred.non_finite_rejected;
  } else {
    res->unexpected = cv::Mat::zeros(size, CV_8U);
    res->accumulated = cv::Mat::zeros(size, CV_32F);  // no history survives a full restart
  }
  res->unexpected_share = cv::countNonZero(res->unexpected) / n_pixels;
  res->regions = LabelRegions(res->unexpected, res->disparity, camera_, T_base_cam0);
  res->timings.plan_ms += MsSince(t0);

  // The state for the next frame. The result's images are never written again: the next
  // frame allocates its own.
  t0 = Clock::now();
  // Points: kept exactly where the prediction stands (no rounding to pixel centres), fresh from
  // the disparity where SGBM ran, and from the background-preferring fill where nothing is known.
  const cv::Mat filled_points = PointsFromDisparity(FillUnknownDisparity(res->disparity), camera_);
  if (mode == FrameMode::kPredicted) {
    state_.points = pred.points;  // owned by this frame's prediction, not by the result
    const cv::Mat fresh_points = PointsFromDisparity(res->disparity, camera_);
    fresh_points.copyTo(state_.points, res->recompute);
    for (int v = 0; v < size.height; ++v) {
      auto* p = state_.points.ptr<cv::Vec3f>(v);
      const auto* f = filled_points.ptr<cv::Vec3f>(v);
      for (int u = 0; u < size.width; ++u) {
        if (!(p[u][2] > 0)) p[u] = f[u];  // no point (NaN): the fill's
      }
    }
  } else {
    state_.points = filled_points;
  }
  state_.flags = cv::Mat(size, CV_8U, cv::Scalar(0));
  state_.flags.setTo(kMeasured, res->disparity > 0);  // false for NaN
  cv::Mat dynamic_flag = state_.flags | kDynamic;
  dynamic_flag.copyTo(state_.flags, res->unexpected);
  state_.image = left.clone();
  state_.accumulated = res->accumulated;
  if (mode == FrameMode::kPredicted && params_.history_reset_px > 0) {
    // Errors explained by a wrong map are not history: forget them where the map changed.
    const float margin = static_cast<float>(params_.history_reset_px);
    cv::Mat changed(size, CV_8U, cv::Scalar(0));
    for (int v = 0; v < size.height; ++v) {
      const uint8_t* rec = res->recompute.ptr<uint8_t>(v);
      const float* fresh = res->disparity.ptr<float>(v);
      const float* predicted = pred.geometry.ptr<float>(v);
      uint8_t* c = changed.ptr<uint8_t>(v);
      for (int u = 0; u < size.width; ++u) {
        if (rec[u] && std::abs(fresh[u] - predicted[u]) > margin) c[u] = 255;  // false for NaN
      }
    }
    if (cv::countNonZero(changed) > 0) {
      state_.accumulated = res->accumulated.clone();  // the result's C stays as published
      state_.accumulated.setTo(0, changed);
    }
  }
  res->timings.fuse_ms = MsSince(t0);

  res->mode = mode;
  ++counters_.frames;
  switch (mode) {
    case FrameMode::kFirst:
      ++counters_.full_first;
      break;
    case FrameMode::kPredicted:
      ++counters_.predicted;
      break;
    case FrameMode::kRefreshScheduled:
      ++counters_.full_scheduled;
      break;
    case FrameMode::kRefreshShare:
      ++counters_.full_share;
      break;
    case FrameMode::kPoseJump:
      ++counters_.pose_jumps;
      break;
  }
  counters_.non_finite_rejected += static_cast<uint64_t>(res->non_finite_rejected);
  frames_since_full_ = mode == FrameMode::kPredicted ? frames_since_full_ + 1 : 0;
  if (mode != FrameMode::kPredicted) refresh_requested_ = false;
  has_state_ = true;
  last_stamp_ns_ = stamp_ns;
  last_T_base_cam0_ = T_base_cam0;
  ++frame_index_;
  res->timings.total_ms = MsSince(t_start);
  return res;
}

}  // namespace epmap::ep
