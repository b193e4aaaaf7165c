#pragma once
// The EP generator (paper 000, Sec. IV-A and IV-B, Fig. 5): from the map at frame k and the
// camera's motion to frame k+1 it predicts
//   D_-^{k+1} = p_D(D^k; T^{k+1})            the disparity (Sec. IV-B),
//   L_-^{k+1} = p(L^k; T^{k+1}, D_-^{k+1})   the left image (Sec. IV-A),
//   C_-^{k+1} = p(C^k; T^{k+1}, D_-^{k+1})   the accumulated error (Sec. IV-A),
// and the holes: pixels of frame k+1 that nothing of frame k explains (newly visible border,
// disocclusions).
//
// The map is kept as one 3-D point per pixel (camera frame), not as a disparity at the pixel
// centre: p_D moves each point rigidly by T_{k+1,k} and re-projects it. A point is stored as its
// disparity and where it lies from its pixel's centre (two 16-bit sub-pixel offsets): 8 bytes
// instead of 12 for x, y, z, and the splat no longer re-derives each point's position to
// compare it with a rival. Points keep their exact positions from frame to frame, so that a depth
// edge moves with the camera by fractions of a pixel per frame; re-deriving the points from pixel
// centres each frame (our first version) rounds every edge back onto the grid each frame, and under
// slow motion the predicted edges stayed put while the real ones moved (measured: bad-2 of the map
// grew by ~9 points in 60 frames of a synthetic pan, versus none with points). Each pixel takes the
// nearest point (z-buffer), then, if still empty, the best point of a neighbour projecting within
// splat_radius_px of its centre; single-pixel cracks within one surface are closed by
// averaging, and small interior holes by interpolation along their row.
//
// L_- and C_- are sampled backwards: each pixel centre of the comparison grid is back-projected
// at its point's depth into frame k, where L^k (full resolution) and C^k are interpolated
// bilinearly (forward splatting intensities would leave cracks and round positions). The
// comparison grid is every image_step-th pixel in x and y: the comparator does not need every
// pixel to find a hand, and at step 2 it costs a quarter.
// Geometry is the rectified left camera (pinhole fx, fy, cx, cy; depth z = fx * baseline / d).

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>

#include "perception/stereo/rectification.h"

namespace epmap::ep {

// Per-point flags, carried along with the points (bits of a CV_8U image).
enum PointFlags : uint8_t {
  kMeasured = 1,  // the point is a stereo measurement (else a fill for an SGBM failure)
  kDynamic = 2,   // the point belonged to something found moving on its own
  kUnseen = 4,    // a fill for content SGBM has never seen (it lay in SGBM's blind margins)
  // Bits 3-6: how many more times SGBM is to try again at a fill it was asked for where the
  // geometry was in question (what a moving thing uncovers is hidden from the right camera for
  // a few frames: occluded, unmatched). 0 = none. Carried with the point; the generator's own
  // fills (cracks, small holes) do not inherit it.
  kRetryShift = 3,
  kRetryMask = 0x78,
};

// A point's offset from its pixel centre is stored in units of 1 / kOffsetScale px (CV_16SC2:
// +-32 px, far more than a splat footprint; a 0.0005 px rounding, far below SGBM's 1/16 px).
constexpr float kOffsetScale = 1024.0F;

// The map at frame k, as the generator needs it: per pixel one point, at disparity d (its
// depth z = fx * baseline / d) on the ray through (u + ou / kOffsetScale, v + ov / kOffsetScale).
struct MapState {
  cv::Mat disparity;    // CV_32F d of each pixel's point; NaN (or <= 0) = none
  cv::Mat offsets;      // CV_16SC2 (ou, ov) of each point
  cv::Mat flags;        // CV_8U PointFlags of each point
  cv::Mat image;        // CV_8U grey L^k, full resolution
  cv::Mat accumulated;  // CV_32F C^k (grey levels), on the comparison grid
};

struct PredictionParams {
  // L_- and C_- are predicted on every image_step-th pixel in x and y (1 or 2).
  int image_step = 2;
  // A moved point is offered to every pixel whose centre lies within this distance (in x and
  // in y) of its projection; each pixel keeps the best offer. 0.5 = nearest pixel only.
  // (Nearest-pixel splatting alone lets the slightly irregular lattice of exact points collide
  // here and gap there; on the head scenario 0.75 saves ~3% of SGBM area for the gaps but costs
  // more CPU than that saves.)
  double splat_radius_px = 0.5;
  // Neighbouring points within this disparity difference belong to one surface (cracks are
  // closed between them; between two surfaces the nearer point wins).
  double crack_max_step_px = 1.0;
  // Holes at most this wide and tall (pixels) that keep away from the image border by more
  // than their size are filled along their row from their neighbours (see FillSmallHoles in
  // ep_generator.cc); 0 disables. Each such hole would otherwise cost an SGBM box whose
  // padding dwarfs it, and SGBM in a small box lacks the context of the full frame (measured
  // on the head scenario: bad-2 of 2x2 targets 14% with 8 px of context, 8% on the full frame).
  int max_hole_fill_px = 4;
  // Points nearer than this to the new camera are dropped (behind it or degenerate).
  double min_depth_m = 0.05;

  void Validate() const;  // std::invalid_argument with the reason
};

struct Prediction {
  cv::Mat disparity;  // D_-: CV_32F, NaN where unknown (holes, and where the point is a fill)
  cv::Mat geometry;   // CV_32F disparity of every predicted point (measured or fill), NaN at holes
  cv::Mat offsets;    // CV_16SC2 where the moved points lie from their pixel centres (MapState)
  cv::Mat flags;      // CV_8U PointFlags of the predicted points (0 at holes)
  cv::Mat holes;      // CV_8U, 255 where nothing of frame k projects (or is non-finite)
  // On the comparison grid (full size / image_step):
  cv::Mat image;                // L_-: CV_32F grey levels, 0 where invalid
  cv::Mat accumulated;          // C_-: CV_32F, 0 where invalid
  cv::Mat image_valid;          // CV_8U 255 where L_- and C_- exist
  int non_finite_rejected = 0;  // values that came out non-finite and were made holes
  int hole_pixels = 0;          // pixels of `holes`
  // Where Predict's time went (wall clock, ms): moving and landing the points, the footprint,
  // crack and hole fills, the full-size outputs with L_- and C_- on the comparison grid (one
  // pass).
  struct Timings {
    double splat_ms = 0, fill_ms = 0, output_ms = 0;
  } timings;
};

// Memory a caller may lend to Predict so that the same large buffers are not allocated (and
// first touched, page by page) at every frame: about a tenth of a frame's work. Predict writes
// into it; the Prediction's offsets, flags and geometry then live there (the offsets
// alternate between two buffers, so that a state made of the last prediction can be read while
// the next one is written; the disparity has its own buffer, which the caller may keep). Give
// one scratch to one pipeline; never publish what lives in it.
struct PredictionScratch {
  cv::Mat offsets[2], flags, splat_disparity, geometry;
};

// T_cur_prev maps points of the previous camera frame into the current one
// (T_cur_prev = T_base_cam0(k+1)^-1 * T_base_cam0(k)). Throws std::invalid_argument if the
// state's images disagree in size or type with each other or with the camera, or if
// T_cur_prev is not finite.
Prediction Predict(const MapState& previous, const Eigen::Isometry3d& T_cur_prev,
                   const stereo::RectifiedGeometry& camera, const PredictionParams& params = {},
                   PredictionScratch* scratch = nullptr);

// The size of the comparison grid for a camera and a step.
cv::Size ComparisonGrid(const stereo::RectifiedGeometry& camera, int image_step);

// Sets the map's points from a disparity image (CV_32F): one point at each pixel centre, none
// (NaN) where the disparity is not above min_disparity_px or not finite.
void SetPointsFromDisparity(const cv::Mat& disparity, MapState* state,
                            double min_disparity_px = 0.25);

}  // namespace epmap::ep
