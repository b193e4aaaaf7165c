#pragma once
// Paper 002, Sec. 3.1 and 3.3: Shi-Tomasi point features, matched left/right (a coarse
// disparity from a stereo correlation at lower resolution seeds the Lucas-Kanade matcher), back
// projected to 3-D, and tracked from one key frame to the next. When the image displacement is
// large (the robot turns, the head pans), each feature's position in the new image is predicted
// from its 3-D position and the planned/odometry motion, and the tracker starts there.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "perception/stereo/rectification.h"
#include "perception/stereo/sgbm.h"

namespace epmap::localisation {

struct StereoFeatureParams {
  int max_features = 300;        // Shi-Tomasi corners per key frame
  double quality_level = 0.001;  // weak corners too: plain walls have few strong ones
  double min_distance_px = 6.0;
  int block_size = 5;
  int lk_window_px = 21;                 // Lucas-Kanade window (odd)
  int lk_levels = 3;                     // pyramid levels above the image
  double max_forward_backward_px = 1.0;  // a track must come back to where it started
  double max_row_error_px = 1.0;         // rectified: left and right rows must agree
  double min_disparity_px = 0.5;
  double max_range_m = 20.0;
  int coarse_scale = 2;             // the seeding stereo correlation runs at 1/coarse_scale
  int coarse_num_disparities = 48;  // at the coarse scale (x coarse_scale at full size)
  double disparity_sigma_px = 0.3;  // stereo matching noise, for the points' sigmas
  double min_point_sigma_m = 0.02;
  int border_px = 4;  // predictions closer than this to the border are dropped
  void Validate() const;
};

struct StereoFeature {
  cv::Point2f left, right;  // rectified pixels
  Eigen::Vector3d p_cam;    // metres, rectified left camera
};

// The point (rectified left camera, metres) of left pixel l at disparity d > 0 px.
Eigen::Vector3d Backproject(const stereo::RectifiedGeometry& camera, const cv::Point2f& l,
                            double d);

// Depth uncertainty of a stereo point at depth z: z^2 sigma_d / (f b), at least min_sigma.
double DepthSigma(const stereo::RectifiedGeometry& camera, double z, double disparity_sigma_px,
                  double min_sigma_m);

// Features of one key frame with what tracking needs from it.
struct KeyFrameFeatures {
  cv::Mat left, right;  // grey, rectified
  std::vector<StereoFeature> features;
  Eigen::Isometry3d T_base_cam = Eigen::Isometry3d::Identity();
};

// Pairs of 3-D positions of the features tracked from one key frame (X') to the next (X''),
// both in the base frame of their own key frame, with a sigma per pair.
struct TrackedPairs {
  std::vector<Eigen::Vector3d> x_prev, x_cur;
  std::vector<double> sigma;
  size_t predicted = 0;       // features whose prediction fell in the new image
  size_t tracked_left = 0;    // ... tracked in the new left image (forward-backward ok)
  size_t tracked_stereo = 0;  // ... and in the new right image, with a valid disparity
};

class StereoFeatureTracker {
 public:
  // Throws std::invalid_argument on a bad camera or parameters.
  StereoFeatureTracker(const stereo::RectifiedGeometry& camera, const StereoFeatureParams& params);

  // Detects and left/right matches the features of a rectified pair (grey or BGR).
  KeyFrameFeatures Detect(const cv::Mat& left, const cv::Mat& right,
                          const Eigen::Isometry3d& T_base_cam) const;

  // Tracks prev's features into the next key frame (left and right tracked separately, each
  // starting at its predicted position). T_cur_prev_predicted maps base(prev) points into
  // base(cur): the planned or odometry motion.
  TrackedPairs Track(const KeyFrameFeatures& prev, const KeyFrameFeatures& cur,
                     const Eigen::Isometry3d& T_cur_prev_predicted) const;

  const stereo::RectifiedGeometry& camera() const { return camera_; }
  const StereoFeatureParams& params() const { return params_; }

 private:
  stereo::RectifiedGeometry camera_;
  StereoFeatureParams params_;
  std::shared_ptr<stereo::SgbmMatcher> coarse_;
};

}  // namespace epmap::localisation
