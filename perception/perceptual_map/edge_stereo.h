#pragma once
// Paper 003, Sec. III-A: edge points with a sub-pixel location in both images of a rectified
// pair, matched left/right along the same row, weak matches removed, and their position from
// the disparity (Eq. 1-2). Points farther than 20 m are dropped (Sec. III-A-2).
//
// The paper uses the right image as reference; we use the rectified left camera (cam0), the
// frame every other map of the project refers to. The equations are the same.

#include <Eigen/Core>
#include <cstddef>
#include <opencv2/core.hpp>
#include <vector>

#include "perception/stereo/rectification.h"

namespace epmap::perceptual_map {

// The rectified left camera and the baseline (perception/stereo's model of a rectified rig).
using StereoCamera = stereo::RectifiedGeometry;
// Throws std::invalid_argument naming the bad value (focal length, principal point, baseline).
void ValidateCamera(const StereoCamera& camera);

struct EdgeStereoParams {
  double blur_sigma_px = 0.8;  // Gaussian smoothing before the gradient (0 = none)
  double min_gradient = 8.0;   // |dI/dx| in grey levels per pixel for an edge point
  // Only edges at least atan(1 / max_slope) from the image's horizontal: a horizontal edge has
  // no reliable disparity along the row (the same reasoning as paper 002, Sec. 3.2). 3 keeps
  // edges 18 degrees or more from horizontal: the base of a wall seen in perspective (skirting
  // boards along a corridor) is often the only structure a plain wall shows.
  double max_slope = 3.0;  // |dI/dy| <= max_slope * |dI/dx|
  // > 0: after matching, the disparity is refined within +-this many pixels by minimising the
  // squared grey difference over the matching window, every pixel of it, not only the two
  // gradient peaks. Off by default: on the synthetic building it makes edge disparities 17-44 %
  // more accurate yet the perceptual map covers less, and on the real pairs of ../shared/data it
  // makes them less accurate (`epmap-bench edges`, this folder's README).
  double refine_disparity_px = 0.0;
  double min_disparity_px = 0.5;
  double max_disparity_px = 64.0;
  int window_half_width = 3;  // matching window (2w+1) x (2h+1) around each edge point
  int window_half_height = 2;
  double max_mean_abs_diff = 12.0;  // weak matches: mean |L-R| over the window above this
  double uniqueness = 0.85;         // weak matches: best cost > uniqueness * second best
  double max_gradient_ratio = 2.0;  // |gx| of the two points may differ at most by this factor
  bool left_right_check = true;     // keep only mutual best matches
  // Weak matches: a right edge that two or more left edges pick as their best acceptable match
  // is contested, and none of them is kept. Repeated structure on a plain wall (the two jambs of
  // a door) matches across: the mutual check keeps the better-looking pair even when it is the
  // wrong one, a point metres nearer than the wall. Off by default (see this folder's README:
  // fewer gross errors, the maps' figures within their spread).
  bool reject_contested = false;
  double max_range_m = 20.0;  // paper 003: points beyond 2000 cm are dropped
  void Validate() const;
};

struct EdgePoint {
  float u = 0, v = 0;     // sub-pixel column and row in the left image
  float disparity = 0;    // px, > 0
  float slope = 0;        // |dI/dy| / |dI/dx| at the edge: 0 vertical, 1 at 45 degrees
  Eigen::Vector3d p_cam;  // metres in the rectified left camera frame (x right, y down, z fwd)
};

struct EdgeStereoStats {
  size_t left_edges = 0;
  size_t right_edges = 0;
  size_t matched = 0;
  size_t rejected_weak = 0;   // no candidate good or unique enough
  size_t rejected_range = 0;  // beyond max_range_m
};

// One image's edge points on one row, ordered by column.
struct RowEdge {
  float u = 0;      // sub-pixel column
  float gx = 0;     // signed horizontal gradient at the edge (grey levels / px)
  float slope = 0;  // |dI/dy| / |dI/dx|
};

// Edge points of a grey image (CV_8UC1 or CV_32FC1), one vector per row: local maxima of
// |dI/dx| along the row above min_gradient, located to sub-pixel precision by a parabola
// through the gradient magnitude at the three pixels around the maximum.
std::vector<std::vector<RowEdge>> DetectRowEdges(const cv::Mat& grey, const EdgeStereoParams& p);

// Matches the edge points of a rectified pair (grey or BGR, same size) and triangulates them
// (Eq. 1-2). Throws std::invalid_argument on empty or mismatched images or bad parameters.
std::vector<EdgePoint> MatchEdgePoints(const cv::Mat& left, const cv::Mat& right,
                                       const StereoCamera& camera, const EdgeStereoParams& params,
                                       EdgeStereoStats* stats = nullptr);

// Eq. 1-2 (and the row for y): position in the camera frame of a point at column u, row v
// with disparity d > 0.
Eigen::Vector3d Triangulate(const StereoCamera& camera, double u, double v, double disparity);

}  // namespace epmap::perceptual_map
