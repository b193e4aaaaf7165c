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
// centre: p_D moves each point rigidly by T_{k+1,k} and re-projects it; the nearest point wins
// a pixel (z-buffer); single-pixel cracks between points of one surface are closed by
// averaging. Points keep their exact positions from frame to frame, so a depth edge moves with
// the camera by fractions of a pixel per frame; re-deriving the points from pixel centres each
// frame (our first version) rounds every edge back onto the grid each frame, and under slow
// motion the predicted edges stayed put while the real ones moved (measured: bad-2 of the map
// grew by ~9 points in 60 frames of a synthetic pan, versus none with points).
// L_- and C_- are sampled backwards: each predicted pixel centre is back-projected at its
// point's depth into frame k, where L^k and C^k are interpolated bilinearly (forward splatting
// intensities would leave cracks and round positions).
// Geometry is the rectified left camera (pinhole fx, fy, cx, cy; depth z = fx * baseline / d).

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "perception/stereo/rectification.h"

namespace epmap::ep {

// The map at frame k, as the generator needs it.
struct MapState {
  cv::Mat points;       // CV_32FC3 3-D point per pixel, camera frame k (m); NaN = none
  cv::Mat measured;     // CV_8U, 255 where the point is a stereo measurement (else a fill)
  cv::Mat image;        // CV_8U grey L^k
  cv::Mat accumulated;  // CV_32F C^k (grey levels)
};

struct PredictionParams {
  // A single-pixel crack between two predicted neighbours is closed when their disparities
  // differ by at most this much (one surface); else it stays a hole (a disocclusion).
  double crack_max_step_px = 1.0;
  // Points nearer than this to the new camera are dropped (behind it or degenerate).
  double min_depth_m = 0.05;
};

struct Prediction {
  cv::Mat disparity;  // D_-: CV_32F, NaN where unknown (holes, and where the point is a fill)
  cv::Mat geometry;   // CV_32F disparity of every predicted point (measured or fill), NaN at holes
  cv::Mat points;     // CV_32FC3 the moved points, camera frame k+1; NaN at holes
  cv::Mat measured;   // CV_8U, 255 where disparity is a propagated measurement
  cv::Mat image;      // L_-: CV_32F grey levels, 0 at holes
  cv::Mat accumulated;          // C_-: CV_32F, 0 at holes
  cv::Mat holes;                // CV_8U, 255 where nothing of frame k projects (or is non-finite)
  cv::Mat source_x;             // CV_32F column in frame k each pixel was sampled at, -1 at holes
  int non_finite_rejected = 0;  // values that came out non-finite and were made holes
};

// T_cur_prev maps points of the previous camera frame into the current one
// (T_cur_prev = T_base_cam0(k+1)^-1 * T_base_cam0(k)). Throws std::invalid_argument if the
// state's images disagree in size or type with each other or with the camera, or if
// T_cur_prev is not finite.
Prediction Predict(const MapState& previous, const Eigen::Isometry3d& T_cur_prev,
                   const stereo::RectifiedGeometry& camera, const PredictionParams& params = {});

// Back-projects a disparity map (CV_32F, NaN or <= min_disparity_px = none) into one point per
// pixel centre (CV_32FC3, camera frame, NaN = none).
cv::Mat PointsFromDisparity(const cv::Mat& disparity, const stereo::RectifiedGeometry& camera,
                            double min_disparity_px = 0.25);

}  // namespace epmap::ep
