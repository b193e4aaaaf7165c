#pragma once
// The expected-perception (EP) disparity map of paper 000 ("An Expected Perception
// Architecture using Visual 3D Reconstruction for a Humanoid Robot"), Fig. 3 and 5: fed one
// rectified stereo frame and the camera pose at a time, it
//   1. predicts the disparity D_-, the left image L_- and the accumulated error C_- from the
//      previous map and the camera's motion (generator/, Sec. IV-A/B);
//   2. compares prediction and reality: E, C, A and the thresholded unexpected regions
//      (comparator/, Sec. IV-A);
//   3. recomputes SGBM only where the prediction failed (update/, Sec. IV-B) and fuses it in.
// The first frame, frames after a pose jump, and refreshes by policy are computed whole.
//
// Two masks come out: `unexpected` is the motion detector (something moved on its own: A above
// the threshold where the prediction was valid), `recompute` is what SGBM was run on: the
// unexpected regions grown by a margin, where something moved last frame, holes (disocclusions,
// and newly visible border strips once thick enough), content that left SGBM's blind margins,
// and one band of rows of the rolling refresh.
//
// Measured on `epmap-sim record --scenario head` (300 frames, see README.md): without the
// rolling refresh the map degrades (bad-2 0.28 against 0.18 for full-frame SGBM: SGBM's
// failures accumulate and wrong values on textureless surfaces are seen neither by E nor by
// the stereo check); with a 20-frame period it stays better than full-frame SGBM (0.14). The
// stereo consistency check (comparator/stereo_check.h) brought nothing once the rolling refresh
// was on (bad-2 0.157 with it, 0.157 without, for more work): it is off by default.
//
// Use: one object per camera pipeline, Process() once per stereo frame, from one thread. Each
// result is immutable and owns its images (nothing is shared with the object's later state), so
// it can be published to readers as it is.

#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "perception/ep/comparator/regions.h"
#include "perception/ep/comparator/stereo_check.h"
#include "perception/ep/comparator/visual_comparator.h"
#include "perception/ep/generator/ep_generator.h"
#include "perception/ep/update/roi_stereo.h"
#include "perception/stereo/rectification.h"
#include "perception/stereo/sgbm.h"

namespace epmap::ep {

// When the whole frame is recomputed besides the first frame (not in the paper, whose map is
// only ever updated where the prediction fails; 0 / >= 1 disable a rule).
struct RefreshPolicy {
  int every_n_frames = 0;            // a full SGBM every N frames
  double max_recompute_share = 0.5;  // or when more than this share would be recomputed anyway
  // A band of rows is recomputed every rolling_every_frames frames, cycling down the image, so
  // that every pixel is measured afresh at least every rolling_period_frames frames (N): the
  // cost is spread over the frames instead of a full frame now and then. 0 disables.
  int rolling_period_frames = 20;
  // One band of ceil(height / floor(N / k)) rows every k frames. SGBM pays a fixed overhead per
  // box (its context rows and OpenCV's stripe restarts, ~20 rows): a 96-row band every 4th
  // frame costs less than four 24-row bands, at the price of a slower frame in four (head
  // scenario: mean EP time -4 to -10%, mean CPU -9%, bad-2 0.135 -> 0.132; ep README).
  int rolling_every_frames = 4;
};

struct EpParams {
  PredictionParams prediction;
  ComparatorParams comparator;
  StereoCheckParams stereo_check;
  stereo::SgbmParams sgbm;
  RoiStereoParams roi;
  RefreshPolicy refresh;
  // A camera moving faster than this between two frames is not trusted to predict from (an
  // encoder glitch, a pose from the wrong frame): the frame is computed whole and counted.
  // Rates, not steps per frame, so that one bound suits any frame rate and a dropped frame is
  // no jump: the defaults are the 0.15 rad and 5 cm per frame of the 30 Hz head. (As steps they
  // rejected a 10 Hz base driving at 0.5 m/s: 1113 of the building run's 1849 frames.) The
  // interval is taken as at least min_frame_interval_s, so that stamps closer than any camera's
  // frame period do not turn encoder noise into jumps, and as at most max_frame_interval_s, so
  // that a glitch cannot hide in a dropout (after a long gap, a motion beyond what that interval
  // allows is computed whole).
  double max_rotation_rate_rad_s = 4.5;
  double max_translation_speed_m_s = 1.5;
  double min_frame_interval_s = 0.01;
  double max_frame_interval_s = 0.25;
  // A head that pans in steps beyond the bound often comes back to where it was a moment ago
  // (a look-around: -30, -60, -30, 0, 30, 60, 30 degrees). On a pose jump the EP keeps the map
  // it leaves, up to earlier_views of them, for earlier_view_max_age_s; a later frame whose
  // pose is within the bound of one of them (as if it were the previous frame) is predicted
  // from it instead of being computed whole, and can be compared. 0 disables. Our addition.
  // The age limit keeps it to the head's returns (0.2-0.4 s in a look-around): across a turn of
  // the base (1.6 s later, 15 degrees away) the odometry's turn error, 0.6 degrees over 45,
  // mispredicted every edge (12% of a frame flagged, building run).
  int earlier_views = 4;
  double earlier_view_max_age_s = 0.5;
  // Unexpected regions are grown by this margin before recomputing (their edges change too).
  int recompute_margin_px = 3;
  // Newly visible content along an image border is recomputed once the strip is this thick
  // (until then it stays unknown): an SGBM box for a 2-pixel strip costs the strip plus the
  // whole search range and the block's context, 50 times the strip. <= 1 recomputes at once.
  int border_batch_px = 8;
  // A flagged pixel whose fresh disparity is clearly behind the prediction (by more than this)
  // shows background that a moving thing uncovered: it needs its new disparity, but the thing
  // that moved is no longer there, so it is left out of the unexpected (motion) mask.
  // <= 0 disables this. Our addition, not in the paper.
  double uncovered_margin_px = 1.0;
  // SGBM searches only the disparity range the prediction expects in a region (with a margin,
  // see RoiStereoParams), except where something moved or the pair disagrees: the search
  // range is most of SGBM's cost.
  bool narrow_search = true;
  // Pixels found unexpected are marked dynamic in the map; next frame, wherever the prediction
  // comes from dynamic points, SGBM re-measures (a moving thing's geometry is stale at once, and
  // where it leaves a low-texture surface neither E nor the stereo check would notice). Our
  // addition, not in the paper.
  bool remeasure_dynamic = true;
  // Where SGBM, recomputing a region whose geometry was in question (found unexpected, dynamic
  // or inconsistent), finds the predicted disparity off by more than this, the accumulated
  // error C there is reset to 0: the errors were the map's fault, not predictable noise, and C
  // must not keep attenuating that place once the map is right (else a moving thing leaves a
  // trail that the comparator has learnt to ignore: "burn-in"). Not on the rolling refresh band:
  // there a 1 px disagreement is SGBM's own noise, and resetting C at every edge of the band
  // every rolling period undid the attenuation of the predictable errors (Fig. 6k; measured on
  // the head scenario: A/E on the still background 0.558 before, 0.546 after, IoU unchanged).
  // <= 0 disables. Our addition, not in the paper.
  double history_reset_px = 1.0;
  // Where SGBM, recomputing a region whose geometry was in question, finds no match (the map
  // keeps a fill there, unknown), it tries again, up to retry_unmatched_frames times, until it
  // finds one: background a moving thing just uncovered in the left image is
  // still hidden from the right one for as many frames as the thing takes to move by the
  // difference of their disparities, and without a retry the fill stays (E does not notice a
  // wrong fill on a plain wall) until the rolling refresh comes by. 0..15; 0 disables. Our
  // addition, not in the paper.
  int retry_unmatched_frames = 4;
  // ... trying on one frame in this many (the occlusion clears over several frames; each try
  // costs an SGBM box).
  int retry_every_frames = 4;

  void Validate() const;  // std::invalid_argument with the reason
};

enum class FrameMode {
  kFirst,             // no previous map: full SGBM
  kPredicted,         // EP: SGBM only where needed
  kRefreshScheduled,  // full SGBM by RefreshPolicy::every_n_frames (still compared)
  kRefreshShare,      // full SGBM because the recompute share exceeded the bound (compared)
  kPoseJump,          // the camera moved more than the bound: full SGBM, nothing compared
};
const char* ToString(FrameMode mode);

struct EpTimings {
  double predict_ms = 0;        // generator: D_-, L_-, C_-
  Prediction::Timings predict;  // ... of which its parts
  double compare_ms = 0;        // comparator: E, C, A, threshold, specks; stereo check
  double plan_ms = 0;           // recompute mask, unexpected mask, regions
  double stereo_ms = 0;         // SGBM (regions or full frame)
  double fuse_ms = 0;           // map update and the state for the next frame
  double total_ms = 0;
};

struct EpResult {
  int64_t stamp_ns = 0;
  uint64_t frame_index = 0;  // 0 for the first frame after construction or Reset()
  FrameMode mode = FrameMode::kFirst;
  bool from_earlier_view = false;  // predicted from an earlier view's map (after a pose jump)
  Eigen::Isometry3d T_base_cam0 = Eigen::Isometry3d::Identity();

  cv::Mat disparity;  // the EP map D^{k+1}: CV_32F px, NaN = unknown
  // On the comparison grid (every prediction.image_step-th pixel in x and y):
  cv::Mat predicted_left;  // L_-: CV_32F grey levels, 0 at holes (empty on full-only frames)
  cv::Mat error;           // E: CV_32F (empty when nothing was compared)
  cv::Mat accumulated;     // C: CV_32F (zeros when nothing was compared)
  cv::Mat attenuated;      // A: CV_32F (empty when nothing was compared)
  // At full resolution:
  cv::Mat unexpected;           // CV_8U 255: moved on its own (the motion detector output)
  cv::Mat recompute;            // CV_8U 255: where SGBM gave fresh values (all 255 on full frames)
  cv::Mat holes;                // CV_8U 255: nothing predicted (empty when nothing was compared)
  cv::Mat stereo_inconsistent;  // CV_8U 255: D_- disagrees with the pair (empty if not checked)
  std::vector<Region> regions;  // connected components of `unexpected`

  bool compared = false;         // E, A, means are meaningful
  double recomputed_share = 0;   // share of pixels given fresh SGBM values
  double stereo_area_share = 0;  // SGBM's processed area (padded boxes) / image area
  double hole_share = 0;
  double unexpected_share = 0;
  double mean_error = 0;       // mean E over predicted pixels (Fig. 6k)
  double mean_attenuated = 0;  // mean A over predicted pixels (Fig. 6k)
  double exposure_gain = 1, exposure_offset = 0;
  int sgbm_boxes = 0;
  int non_finite_rejected = 0;  // predicted values that came out non-finite (made holes)
  EpTimings timings;
};

struct EpCounters {
  uint64_t frames = 0;
  uint64_t predicted = 0;
  uint64_t full_first = 0;
  uint64_t full_scheduled = 0;
  uint64_t full_share = 0;
  uint64_t pose_jumps = 0;
  uint64_t from_earlier_view = 0;  // of the predicted frames, those predicted from an earlier
                                   // view's map (EpParams::earlier_views)
  uint64_t non_finite_rejected = 0;
};

class ExpectedPerception {
 public:
  // camera: the rectified left camera and the stereo baseline. Throws std::invalid_argument on
  // an unusable camera or parameters.
  explicit ExpectedPerception(const stereo::RectifiedGeometry& camera, const EpParams& params = {});

  // One stereo frame: rectified left (CV_8UC1, or BGR converted to grey), rectified right (same
  // size, grey or BGR), the pose of the rectified left camera in the base frame at this frame,
  // and the frame's stamp (must increase). Throws std::invalid_argument with the reason on bad
  // input (wrong size/type, non-finite or non-rigid pose, stamp not after the previous one);
  // the object's state is then unchanged.
  std::shared_ptr<const EpResult> Process(const cv::Mat& left, const cv::Mat& right,
                                          const Eigen::Isometry3d& T_base_cam0, int64_t stamp_ns);

  // Forget the map: the next frame is computed whole (e.g. after a calibration change).
  void Reset();
  // The next frame is computed whole, keeping the comparison history.
  void RequestFullRefresh() { refresh_requested_ = true; }

  const EpCounters& counters() const { return counters_; }
  const EpParams& params() const { return params_; }
  const stereo::RectifiedGeometry& camera() const { return camera_; }

 private:
  stereo::RectifiedGeometry camera_;
  EpParams params_;
  RoiStereo stereo_;
  ComparatorParams grid_comparator_;  // params_.comparator in comparison-grid pixels
  EpCounters counters_;
  bool refresh_requested_ = false;
  uint64_t frames_since_full_ = 0;
  uint64_t frame_index_ = 0;

  bool has_state_ = false;
  int64_t last_stamp_ns_ = 0;
  Eigen::Isometry3d last_T_base_cam0_ = Eigen::Isometry3d::Identity();
  MapState state_;             // points of D^k (measured or filled), their flags, L^k, C^k
  PredictionScratch scratch_;  // the generator's buffers, reused from frame to frame
  // At a pose jump: keeps the map being left among the earlier views and, if the camera is
  // back within the bound of one of them, makes it the state to predict from (true).
  bool ReturnToEarlierView(int64_t stamp_ns,
                           const std::function<bool(const Eigen::Isometry3d&)>& within_bound);
  // The maps left at pose jumps, oldest first (EpParams::earlier_views); they own their buffers.
  struct EarlierView {
    MapState state;
    Eigen::Isometry3d T_base_cam0 = Eigen::Isometry3d::Identity();
    int64_t stamp_ns = 0;
  };
  std::deque<EarlierView> earlier_views_;
};

}  // namespace epmap::ep
