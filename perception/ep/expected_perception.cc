#include "perception/ep/expected_perception.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/cpu/hot_loop.h"
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

// Disparities at or below this give no point (too far to move meaningfully).
constexpr float kMinPointDisparity = 0.25F;

// Runs of `mask` pixels starting at an image edge line and going inwards: along rows from
// column `start` (step +1 or -1), or along columns from row `start`. Returns each line's run
// length in `lengths` and the strip's thickness: the 75th percentile of the run lengths over
// all lines (a strip along this edge makes most lines' runs equally long; a strip along a
// perpendicular edge makes a few lines' runs very long, and must not count).
int EdgeRuns(const cv::Mat& mask, bool along_rows, int start, int step, std::vector<int>* lengths) {
  const int W = mask.cols, H = mask.rows;
  const int lines = along_rows ? H : W;
  lengths->assign(static_cast<size_t>(lines), 0);
  for (int i = 0; i < lines; ++i) {
    int n = 0;
    for (int j = start;; j += step, ++n) {
      const int u = along_rows ? j : i, v = along_rows ? i : j;
      if (u < 0 || v < 0 || u >= W || v >= H || !mask.at<uint8_t>(v, u)) break;
    }
    (*lengths)[static_cast<size_t>(i)] = n;
  }
  std::vector<int> sorted = *lengths;
  auto q = sorted.begin() + static_cast<std::ptrdiff_t>(3 * sorted.size() / 4);
  std::nth_element(sorted.begin(), q, sorted.end());
  return *q;
}

// Every step-th pixel of every step-th row: the comparison grid of an image.
cv::Mat Decimate(const cv::Mat& image, int step) {
  if (step == 1) return image;
  const cv::Size grid((image.cols + step - 1) / step, (image.rows + step - 1) / step);
  cv::Mat out(grid, image.type());
  if (image.type() == CV_8UC1) {  // grey: a plain strided copy the compiler vectorises
    for (int i = 0; i < grid.height; ++i) {
      const uint8_t* __restrict src = image.ptr<uint8_t>(i * step);
      uint8_t* __restrict dst = out.ptr<uint8_t>(i);
      for (int j = 0; j < grid.width; ++j) dst[j] = src[j * step];
    }
    return out;
  }
  const size_t elem = image.elemSize();
  for (int i = 0; i < grid.height; ++i) {
    const uint8_t* src = image.ptr<uint8_t>(i * step);
    uint8_t* dst = out.ptr<uint8_t>(i);
    for (int j = 0; j < grid.width; ++j) {
      std::copy_n(src + static_cast<size_t>(j * step) * elem, elem, dst + j * elem);
    }
  }
  return out;
}

// A mask of the comparison grid back at full resolution (each grid pixel covers step x step):
// one row widened, then copied to the step rows it covers.
cv::Mat Upsample(const cv::Mat& grid_mask, const cv::Size& size, int step) {
  if (step == 1) return grid_mask;
  // Most frames flag nothing: a memset instead of a pass.
  if (cv::countNonZero(grid_mask) == 0) return cv::Mat::zeros(size, CV_8U);
  cv::Mat out(size, CV_8U);
  if (step == 2 && size.width % 2 == 0) {  // the usual case: each byte written twice at once
    for (int v = 0; v < size.height; v += 2) {
      const uint8_t* __restrict src = grid_mask.ptr<uint8_t>(v / 2);
      uint8_t* __restrict dst = out.ptr<uint8_t>(v);
      for (int j = 0; j < size.width / 2; ++j) {
        const uint16_t pair = static_cast<uint16_t>(src[j] * 0x0101U);
        std::memcpy(dst + 2 * j, &pair, sizeof(pair));
      }
      if (v + 1 < size.height) std::memcpy(out.ptr<uint8_t>(v + 1), dst, size.width);
    }
    return out;
  }
  for (int v = 0; v < size.height; v += step) {
    const uint8_t* src = grid_mask.ptr<uint8_t>(v / step);
    uint8_t* dst = out.ptr<uint8_t>(v);
    for (int j = 0, u = 0; u < size.width; ++j) {
      const uint8_t value = src[j];
      for (int k = 0; k < step && u < size.width; ++k, ++u) dst[u] = value;
    }
    for (int r = 1; r < step && v + r < size.height; ++r) {
      std::copy_n(dst, size.width, out.ptr<uint8_t>(v + r));
    }
  }
  return out;
}

// The comparator's parameters for the comparison grid: its sizes are given in full-resolution
// pixels.
ComparatorParams ForGrid(ComparatorParams p, int step) {
  const auto scale = [&](int r) { return r > 0 ? std::max(1, (r + step / 2) / step) : 0; };
  p.open_radius_px = scale(p.open_radius_px);
  p.close_radius_px = scale(p.close_radius_px);
  p.min_region_area_px = p.min_region_area_px / (step * step);
  return p;
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

// Whether any pixel of `flags` (CV_8U) has one of `bits`: eight pixels at a time, stopping at
// the first (a bitwise_and and a countNonZero cost two full passes and an image).
bool AnyFlag(const cv::Mat& flags, uint8_t bits) {
  const uint64_t mask = bits * 0x0101010101010101ULL;
  for (int v = 0; v < flags.rows; ++v) {
    const uint8_t* row = flags.ptr<uint8_t>(v);
    int u = 0;
    for (; u + 8 <= flags.cols; u += 8) {
      uint64_t word;
      std::memcpy(&word, row + u, sizeof(word));
      if (word & mask) return true;
    }
    for (; u < flags.cols; ++u) {
      if (row[u] & bits) return true;
    }
  }
  return false;
}

// The pixels of `flags` (CV_8U) in columns [first, last] with one of `bits`.
EPMAP_HOT_LOOP int CountFlag(const cv::Mat& flags, uint8_t bits, int first, int last) {
  int count = 0;
  const int begin = std::max(first, 0), end = std::min(last + 1, flags.cols);
  for (int v = 0; v < flags.rows; ++v) {
    const uint8_t* row = flags.ptr<uint8_t>(v);
    for (int u = begin; u < end; ++u) count += (row[u] & bits) != 0 ? 1 : 0;
  }
  return count;
}

// What the fusion of one frame reads (see Process, "The state for the next frame"); the
// prediction's images are null on frames computed whole, the optional masks null when empty.
struct FuseInputs {
  bool predicted = false;
  int first_column = 0, last_column = 0, retry_unmatched_frames = 0;
  const cv::Mat* fresh = nullptr;       // the frame's disparity (SGBM where it ran)
  const cv::Mat* recompute = nullptr;   // where SGBM ran
  const cv::Mat* unexpected = nullptr;  // what moved on its own
  const cv::Mat* predicted_geometry = nullptr;
  const cv::Mat* carried_flags = nullptr;
  const cv::Mat* holes = nullptr;
  const cv::Mat* deferred = nullptr;   // thin border strips left for a later frame
  const cv::Mat* uncertain = nullptr;  // where the geometry was in question
};

// Rows [row_begin, row_end) of the next state's points and flags, in two passes per row: the
// flags of every pixel and the predicted points kept (no branches: the compiler vectorises it),
// then the few pixels that take a fresh point (recomputed, or a hole of the prediction).
EPMAP_HOT_LOOP void FuseRows(const FuseInputs& in, int row_begin, int row_end, MapState* state) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int width = in.fresh->cols;
  const bool predicted = in.predicted;
  const int first_column = in.first_column, last_column = in.last_column;
  const int retry_start = in.retry_unmatched_frames;
  // Stands in for the masks a frame does not have (all clear).
  const std::vector<uint8_t> clear(static_cast<size_t>(width), 0);
  for (int v = row_begin; v < row_end; ++v) {
    float* __restrict point_d = state->disparity.ptr<float>(v);
    int16_t* offsets = state->offsets.ptr<int16_t>(v);
    const float* __restrict fresh = in.fresh->ptr<float>(v);
    const uint8_t* __restrict rec = in.recompute->ptr<uint8_t>(v);
    const uint8_t* __restrict moved = in.unexpected->ptr<uint8_t>(v);
    const uint8_t* __restrict carried =
        predicted ? in.carried_flags->ptr<uint8_t>(v) : clear.data();
    const uint8_t* __restrict hole = predicted ? in.holes->ptr<uint8_t>(v) : clear.data();
    const uint8_t* __restrict later = in.deferred ? in.deferred->ptr<uint8_t>(v) : clear.data();
    const uint8_t* __restrict in_question =
        in.uncertain ? in.uncertain->ptr<uint8_t>(v) : clear.data();
    uint8_t* __restrict flags = state->flags.ptr<uint8_t>(v);
    if (predicted) {  // the predicted points stay, where they stand (offsets included)
      std::memcpy(point_d, in.predicted_geometry->ptr<float>(v), sizeof(float) * width);
    }
    for (int u = 0; u < width; ++u) {
      const float d = fresh[u];
      const uint8_t c = carried[u];
      const bool recomputed = rec[u] != 0;
      const bool unknown = d != d;  // NaN
      // Unseen: nothing measured and SGBM never looked (its blind margins, a deferred strip,
      // an unseen point carried along and not recomputed).
      const bool unseen = unknown & ((u < first_column) | (u > last_column) | (later[u] != 0) |
                                     (((c & kUnseen) != 0) & !recomputed));
      // Unmatched where the geometry was in question: tried again, on one frame in
      // retry_every_frames, at most retry_unmatched_frames times; the count waits on the
      // frames between, and ends with a match or any other re-measurement.
      const int retries = (c & kRetryMask) >> kRetryShift;
      const bool retry_now = predicted & (in_question[u] != 0) & recomputed & unknown;
      const int retry =
          retry_now ? (retries > 0 ? retries - 1 : retry_start) : (recomputed ? 0 : retries);
      flags[u] = static_cast<uint8_t>((d > 0 ? kMeasured : 0) | (moved[u] ? kDynamic : 0) |
                                      (unseen ? kUnseen : 0) | (retry << kRetryShift));
    }
    // The fill of SGBM's gaps, only where a pixel needs it (on predicted frames few do).
    RowGap gap;
    for (int u = 0; u < width; ++u) {
      if (predicted) {
        // Most of a row is neither recomputed nor a hole: skipped eight pixels at a time.
        if (u + 8 <= width) {
          uint64_t rec_word, hole_word;
          std::memcpy(&rec_word, rec + u, sizeof(rec_word));
          std::memcpy(&hole_word, hole + u, sizeof(hole_word));
          if ((rec_word | hole_word) == 0) {
            u += 7;
            continue;
          }
        }
        if (!rec[u] && !(hole[u] && !later[u])) continue;
      }
      float d;
      if (predicted && !rec[u]) {  // a hole of the prediction (not on a deferred strip)
        d = FilledDisparityAt(fresh, width, u, &gap);
      } else {  // recomputed (or the frame computed whole): SGBM's value, or the fill of its gap
        d = fresh[u] > kMinPointDisparity ? fresh[u] : FilledDisparityAt(fresh, width, u, &gap);
      }
      // A fresh point, at the pixel centre.
      point_d[u] = d > kMinPointDisparity ? d : nan;  // false for NaN
      offsets[2 * u] = offsets[2 * u + 1] = 0;
    }
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
  prediction.Validate();
  comparator.Validate();
  stereo_check.Validate();
  sgbm.Validate();
  roi.Validate();
  if (refresh.every_n_frames < 0) throw std::invalid_argument("EP: every_n_frames must be >= 0");
  if (refresh.rolling_period_frames < 0 || refresh.rolling_every_frames < 1) {
    throw std::invalid_argument(
        "EP: rolling_period_frames must be >= 0 and rolling_every_frames >= 1");
  }
  if (!(refresh.max_recompute_share > 0)) {
    throw std::invalid_argument("EP: max_recompute_share must be > 0 (>= 1 disables it)");
  }
  if (!(max_rotation_rate_rad_s > 0) || !(max_translation_speed_m_s > 0) ||
      !(min_frame_interval_s > 0) || !(max_frame_interval_s >= min_frame_interval_s)) {
    throw std::invalid_argument(
        "EP: the pose jump bounds (max_rotation_rate_rad_s, max_translation_speed_m_s, "
        "min_frame_interval_s) must be > 0 and max_frame_interval_s >= min_frame_interval_s");
  }
  if (earlier_views < 0 || !(earlier_view_max_age_s >= 0)) {
    throw std::invalid_argument("EP: earlier_views and earlier_view_max_age_s must be >= 0");
  }
  if (recompute_margin_px < 0) throw std::invalid_argument("EP: recompute_margin_px must be >= 0");
  if (border_batch_px < 0) throw std::invalid_argument("EP: border_batch_px must be >= 0");
  if (retry_unmatched_frames < 0 || retry_unmatched_frames > (kRetryMask >> kRetryShift)) {
    throw std::invalid_argument("EP: retry_unmatched_frames must be in 0..15");
  }
  if (retry_every_frames < 1) throw std::invalid_argument("EP: retry_every_frames must be >= 1");
}

ExpectedPerception::ExpectedPerception(const stereo::RectifiedGeometry& camera,
                                       const EpParams& params)
    : camera_(camera),
      params_(params),
      stereo_(params.sgbm, params.roi),
      grid_comparator_(ForGrid(params.comparator, params.prediction.image_step)) {
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
  earlier_views_.clear();
}

bool ExpectedPerception::ReturnToEarlierView(
    int64_t stamp_ns, const std::function<bool(const Eigen::Isometry3d&)>& within_bound) {
  if (params_.earlier_views == 0) return false;
  const auto too_old = [&](const EarlierView& v) {
    return static_cast<double>(stamp_ns - v.stamp_ns) * 1e-9 > params_.earlier_view_max_age_s;
  };
  while (!earlier_views_.empty() && too_old(earlier_views_.front())) earlier_views_.pop_front();
  // The map being left: its offsets may live in the generator's scratch, which the next
  // prediction overwrites, so they are copied (only at pose jumps).
  EarlierView leaving{std::move(state_), last_T_base_cam0_, last_stamp_ns_};
  leaving.state.offsets = leaving.state.offsets.clone();
  state_ = MapState{};
  // The newest earlier view the camera is back at, if any.
  for (auto it = earlier_views_.rbegin(); it != earlier_views_.rend(); ++it) {
    if (!within_bound(it->T_base_cam0)) continue;
    state_ = std::move(it->state);
    last_T_base_cam0_ = it->T_base_cam0;
    earlier_views_.erase(std::next(it).base());
    earlier_views_.push_back(std::move(leaving));
    while (static_cast<int>(earlier_views_.size()) > params_.earlier_views) {
      earlier_views_.pop_front();
    }
    return true;
  }
  earlier_views_.push_back(std::move(leaving));
  while (static_cast<int>(earlier_views_.size()) > params_.earlier_views) {
    earlier_views_.pop_front();
  }
  return false;
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
  // SGBM matches the images as the cameras delivered them (colour when they are colour, as
  // full-frame SGBM would); the comparator works on brightness. The right image's brightness
  // serves only the stereo check, or SGBM when the pair is not colour.
  const bool colour = left_in.type() == CV_8UC3 && right_in.type() == CV_8UC3;
  const cv::Mat right =
      colour && !params_.stereo_check.enabled ? right_in : ToGrey(right_in, "right");
  const cv::Mat& stereo_left = colour ? left_in : left;
  const cv::Mat& stereo_right = colour ? right_in : right;
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
  const int step = params_.prediction.image_step;
  Prediction pred;
  Comparison cmp;
  cv::Mat flagged;           // the comparator's unexpected regions, at full resolution
  cv::Mat deferred;          // thin border strips left for a later frame
  cv::Mat uncertain;         // recomputed regions whose disparity may be anything
  bool any_dynamic = false;  // some of the prediction comes from points that moved on their own
  bool from_earlier_view = false;
  if (has_state_) {
    const double dt_s = std::clamp(static_cast<double>(stamp_ns - last_stamp_ns_) * 1e-9,
                                   params_.min_frame_interval_s, params_.max_frame_interval_s);
    const auto within_bound = [&](const Eigen::Isometry3d& T_before) {
      const Eigen::Isometry3d T_cur_prev = T_base_cam0.inverse() * T_before;
      return Eigen::AngleAxisd(T_cur_prev.linear()).angle() <=
                 params_.max_rotation_rate_rad_s * dt_s &&
             T_cur_prev.translation().norm() <= params_.max_translation_speed_m_s * dt_s;
    };
    const bool jump = !within_bound(last_T_base_cam0_);
    if (jump) from_earlier_view = ReturnToEarlierView(stamp_ns, within_bound);
    if (jump && !from_earlier_view) {
      mode = FrameMode::kPoseJump;
    } else {
      const Eigen::Isometry3d T_cur_prev = T_base_cam0.inverse() * last_T_base_cam0_;
      mode = FrameMode::kPredicted;
      auto t0 = Clock::now();
      pred = Predict(state_, T_cur_prev, camera_, params_.prediction, &scratch_);
      res->timings.predict_ms = MsSince(t0);
      res->timings.predict = pred.timings;
      t0 = Clock::now();
      // Where the prediction comes from points that moved on their own last frame (planned
      // below too): the comparator keeps following what it found moving; and where it comes
      // from a guessed depth: never grown over.
      any_dynamic = AnyFlag(pred.flags, kDynamic);
      const cv::Mat grid_flags = Decimate(pred.flags, step);
      PredictionHints hints;
      if (any_dynamic) cv::bitwise_and(grid_flags, cv::Scalar(kDynamic), hints.moved_before);
      cv::bitwise_and(grid_flags, cv::Scalar(kUnseen), hints.guessed);
      cmp = Compare(pred.image, pred.image_valid, pred.accumulated, Decimate(left, step),
                    grid_comparator_, hints);
      flagged = Upsample(cmp.flagged, size, step);
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
    // Where the geometry itself is in question, SGBM searches the full range; elsewhere the
    // prediction says what disparities to expect. In question: what the comparator flagged
    // (its edges change too: grown by the margin) and, with remeasure_dynamic, where the
    // prediction came from points that moved on their own last frame (the map's geometry there
    // is not to be trusted whether or not E notices: the thing may have left a low-texture
    // place), grown alike: one dilation of the union.
    if (!params_.remeasure_dynamic) any_dynamic = false;
    const bool any_flagged = cv::countNonZero(cmp.flagged) > 0;
    if (!any_flagged && !any_dynamic) {  // most frames: no dilation
      uncertain = cv::Mat::zeros(size, CV_8U);
    } else {
      cv::Mat questioned;
      if (any_dynamic) {
        cv::bitwise_and(pred.flags, cv::Scalar(kDynamic), questioned);
        cv::compare(questioned, 0, questioned, cv::CMP_GT);  // 255 where dynamic
        if (any_flagged) questioned |= flagged;
      } else {
        questioned = flagged;
      }
      if (params_.recompute_margin_px > 0) {
        // Dilated only inside the box of what is in question, grown by the margin (all else
        // stays 0): usually a small part of the image.
        const int margin = params_.recompute_margin_px, k = 2 * margin + 1;
        const cv::Rect box = cv::boundingRect(questioned);
        const cv::Rect roi = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin,
                                      box.height + 2 * margin) &
                             cv::Rect(0, 0, size.width, size.height);
        uncertain = cv::Mat::zeros(size, CV_8U);
        if (!box.empty()) {
          cv::Mat part = uncertain(roi);
          // BORDER_ISOLATED: the part is dilated as an image of its own (outside it all is 0).
          cv::dilate(questioned(roi), part, cv::getStructuringElement(cv::MORPH_RECT, {k, k}),
                     cv::Point(-1, -1), 1, cv::BORDER_CONSTANT | cv::BORDER_ISOLATED);
        }
      } else {
        uncertain = questioned.clone();
      }
    }
    if (!res->stereo_inconsistent.empty()) uncertain |= res->stereo_inconsistent;
    // Fills SGBM left unmatched when the geometry was in question: still in question, on the
    // frames that are a retry's turn.
    if (params_.retry_unmatched_frames > 0 &&
        frame_index_ % static_cast<uint64_t>(params_.retry_every_frames) == 0) {
      if (AnyFlag(pred.flags, kRetryMask)) {
        cv::Mat retry;
        cv::bitwise_and(pred.flags, cv::Scalar(kRetryMask), retry);
        cv::compare(retry, 0, retry, cv::CMP_GT);
        uncertain |= retry;
      }
    }
    cv::bitwise_or(uncertain, pred.holes, recompute);
    // New content along the borders is recomputed once the strip it forms is thick enough to
    // be worth its SGBM box (the box's padding would dwarf a strip of a pixel or two); until
    // then it stays unknown (without points: a hole again next frame, and the strip grows).
    if (params_.border_batch_px > 1) {
      const struct {
        bool rows;
        int start, step;
      } sides[] = {{true, first_column, 1},
                   {true, last_column, -1},
                   {false, 0, 1},
                   {false, size.height - 1, -1}};
      std::vector<int> lengths;
      for (const auto& side : sides) {
        if (EdgeRuns(pred.holes, side.rows, side.start, side.step, &lengths) >=
            params_.border_batch_px) {
          continue;  // thick enough: recomputed now
        }
        // Only the thin strip itself waits: a line's run deeper than the batch thickness is
        // not part of it (it crosses a strip along a perpendicular edge, e.g. the rows of new
        // content along the top seen from the left edge, which would wait for the rolling band).
        const int strip_depth = params_.border_batch_px - 1;
        for (size_t i = 0; i < lengths.size(); ++i) {
          for (int n = 0; n < std::min(lengths[i], strip_depth); ++n) {
            const int j = side.start + side.step * n;
            const int u = side.rows ? j : static_cast<int>(i);
            const int v = side.rows ? static_cast<int>(i) : j;
            if (u < first_column || u > last_column) continue;  // filled there, never deferred
            if (deferred.empty()) deferred = cv::Mat::zeros(size, CV_8U);
            deferred.at<uint8_t>(v, u) = 255;
            recompute.at<uint8_t>(v, u) = 0;
          }
        }
      }
    }
    // Content that comes out of SGBM's blind margins has no measurement, only a fill: it is
    // measured once there is as much of it as a strip of border_batch_px columns down the whole
    // image (its box reaches back over the whole search range: a thinner strip would pay that
    // padding for little); until then it stays unknown.
    {
      const int count = CountFlag(pred.flags, kUnseen, first_column, last_column);
      if (count > 0 && count >= std::max(params_.border_batch_px, 1) * size.height) {
        cv::Mat emerged;
        cv::bitwise_and(pred.flags, cv::Scalar(kUnseen), emerged);
        BlindMargins(first_column, last_column, &emerged, 0);
        recompute.setTo(255, emerged);
      }
    }
    // Rolling refresh: one band of rows every rolling_every_frames frames, so that every pixel
    // is measured afresh at least every rolling_period_frames frames whatever the comparator
    // saw (a wrong disparity on a surface without texture shows neither in E nor in the stereo
    // check).
    if (params_.refresh.rolling_period_frames > 0) {
      const int period = params_.refresh.rolling_period_frames;
      const int every = std::min(params_.refresh.rolling_every_frames, period);
      const int bands = period / every;  // so that the cycle, bands x every, stays <= period
      const int rows = (size.height + bands - 1) / bands;
      const uint64_t slot = frame_index_ % static_cast<uint64_t>(bands * every);
      const int band = static_cast<int>(slot / static_cast<uint64_t>(every));
      const int y0 = band * rows;
      if (slot % static_cast<uint64_t>(every) == 0 && y0 < size.height) {
        recompute(cv::Rect(0, y0, size.width, std::min(rows, size.height - y0))).setTo(255);
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
    res->disparity = pred.disparity;  // its own buffer (not the scratch): the result keeps it
    // Where the geometry is uncertain the search is not narrowed.
    const RoiStereoStats stats =
        stereo_.ComputeMasked(stereo_left, stereo_right, recompute, res->disparity,
                              params_.narrow_search ? pred.geometry : cv::Mat(), uncertain);
    res->recompute = recompute;
    res->recomputed_share = static_cast<double>(stats.target_pixels) / n_pixels;
    res->stereo_area_share = static_cast<double>(stats.computed_pixels) / n_pixels;
    res->sgbm_boxes = stats.boxes;
  } else {
    res->disparity = stereo_.ComputeFull(stereo_left, stereo_right);
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
  // the background a moving thing uncovered (on the comparison grid, then at full resolution).
  t0 = Clock::now();
  if (res->compared) {
    cv::Mat unexpected = cmp.flagged.clone();
    if (params_.uncovered_margin_px > 0) {
      const float margin = static_cast<float>(params_.uncovered_margin_px);
      bool removed = false;
      for (int i = 0; i < unexpected.rows; ++i) {
        uint8_t* u8 = unexpected.ptr<uint8_t>(i);
        const float* fresh = res->disparity.ptr<float>(i * step);
        const float* predicted = pred.geometry.ptr<float>(i * step);
        for (int j = 0; j < unexpected.cols; ++j) {
          // False for NaN.
          if (u8[j] && fresh[j * step] < predicted[j * step] - margin) {
            u8[j] = 0;
            removed = true;
          }
        }
      }
      // What is left of a region may be a speck now (the comparator's mask has none).
      if (removed) unexpected = RemoveSpecks(unexpected, 0, grid_comparator_.min_region_area_px);
    }
    res->unexpected = Upsample(unexpected, size, step);
    res->predicted_left = pred.image;
    res->error = cmp.error;
    res->attenuated = cmp.attenuated;
    res->accumulated = cmp.accumulated;
    res->holes = pred.holes;
    res->mean_error = cmp.mean_error;
    res->mean_attenuated = cmp.mean_attenuated;
    res->exposure_gain = cmp.gain;
    res->exposure_offset = cmp.offset;
    res->hole_share = pred.hole_pixels / n_pixels;
    res->non_finite_rejected = pred.non_finite_rejected;
  } else {
    res->unexpected = cv::Mat::zeros(size, CV_8U);
    // No history survives a full restart.
    res->accumulated = cv::Mat::zeros(ComparisonGrid(camera_, step), CV_32F);
  }
  res->unexpected_share = cv::countNonZero(res->unexpected) / n_pixels;
  res->regions = LabelRegions(res->unexpected, res->disparity, camera_, T_base_cam0);
  res->timings.plan_ms += MsSince(t0);

  // The state for the next frame. The result's images are never written again: the next
  // frame allocates its own.
  t0 = Clock::now();
  // Points: kept exactly where the prediction stands (no rounding to pixel centres), fresh from
  // the disparity where SGBM ran, and from the fill of SGBM's gaps where nothing is known, except
  // on a deferred border strip: it stays without points, a hole again next frame, until it is
  // thick enough to be worth its SGBM box.
  // Flags: measured where the map has a disparity, dynamic where something moved on its own,
  // unseen where nothing was measured and SGBM never looked (its blind margins, unseen points
  // carried along and not recomputed, deferred strips). One pass over the rows.
  const bool predicted = mode == FrameMode::kPredicted;
  state_.offsets = predicted ? pred.offsets  // owned by this frame's prediction, not the result
                             : cv::Mat(size, CV_16SC2);
  // The previous map's buffers (Predict is done with them); fresh ones where they are the
  // prediction's, which is read below.
  state_.flags.create(size, CV_8U);
  if (predicted && state_.flags.data == pred.flags.data) state_.flags = cv::Mat(size, CV_8U);
  state_.disparity.create(size, CV_32F);
  if (predicted && state_.disparity.data == pred.geometry.data) {
    state_.disparity = cv::Mat(size, CV_32F);
  }
  FuseInputs fuse;
  fuse.predicted = predicted;
  fuse.first_column = first_column;
  fuse.last_column = last_column;
  fuse.retry_unmatched_frames = params_.retry_unmatched_frames;
  fuse.fresh = &res->disparity;
  fuse.recompute = &res->recompute;
  fuse.unexpected = &res->unexpected;
  if (predicted) {
    fuse.predicted_geometry = &pred.geometry;
    fuse.carried_flags = &pred.flags;
    fuse.holes = &pred.holes;
  }
  if (!deferred.empty()) fuse.deferred = &deferred;
  if (!uncertain.empty()) fuse.uncertain = &uncertain;
  cv::parallel_for_(cv::Range(0, size.height),
                    [&](const cv::Range& rows) { FuseRows(fuse, rows.start, rows.end, &state_); });
  state_.image = left.clone();
  state_.accumulated = res->accumulated;
  if (predicted && params_.history_reset_px > 0) {
    // Errors explained by a wrong map are not history: forget them where the map changed in a
    // region recomputed because its geometry was in question (on the comparison grid, where C
    // lives).
    const float margin = static_cast<float>(params_.history_reset_px);
    cv::Mat reset;
    // Only the grid pixels inside the box of the uncertain pixels (often none at all).
    const cv::Rect box = cv::boundingRect(uncertain);
    const int i_end = std::min(res->accumulated.rows, (box.y + box.height + step - 1) / step);
    const int j_begin = (box.x + step - 1) / step;
    const int j_end = std::min(res->accumulated.cols, (box.x + box.width + step - 1) / step);
    for (int i = (box.y + step - 1) / step; i < i_end; ++i) {
      const int v = i * step;
      const uint8_t* rec = uncertain.ptr<uint8_t>(v);
      const float* fresh = res->disparity.ptr<float>(v);
      const float* predicted_d = pred.geometry.ptr<float>(v);
      for (int j = j_begin; j < j_end; ++j) {
        const int u = j * step;
        if (rec[u] && std::abs(fresh[u] - predicted_d[u]) > margin) {  // false for NaN
          if (reset.empty()) reset = res->accumulated.clone();  // the result's C stays as published
          reset.at<float>(i, j) = 0.0F;
        }
      }
    }
    if (!reset.empty()) state_.accumulated = reset;
  }
  res->timings.fuse_ms = MsSince(t0);

  res->mode = mode;
  res->from_earlier_view = from_earlier_view;
  ++counters_.frames;
  switch (mode) {
    case FrameMode::kFirst:
      ++counters_.full_first;
      break;
    case FrameMode::kPredicted:
      ++counters_.predicted;
      if (from_earlier_view) ++counters_.from_earlier_view;
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
