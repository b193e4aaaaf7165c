#pragma once
// The unexpected regions as objects (paper 000, Fig. 6j: "unexpected perception"): connected
// components of a mask with their box, area, mean disparity and 3-D centroid, in the camera
// frame and in the base frame.

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

#include "perception/stereo/rectification.h"

namespace epmap::ep {

struct Region {
  cv::Rect box;
  int area_px = 0;
  double mean_disparity_px = 0;  // over the region's pixels with a known disparity (NaN if none)
  int disparity_pixels = 0;      // how many pixels had one
  bool has_centroid = false;     // false when no pixel of the region has a disparity
  // The mean 3-D point of the region's main surface (its points within max(1 px, 15%) of its
  // median disparity: not the background showing at a moving thing's edges), camera frame (m).
  Eigen::Vector3d centroid_cam0 = Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid_base = Eigen::Vector3d::Zero();  // the same in the base frame
};

// mask: CV_8U (non-zero = in a region); disparity: CV_32F, NaN or <= 0 = unknown.
// Components are 8-connected, listed largest first.
std::vector<Region> LabelRegions(const cv::Mat& mask, const cv::Mat& disparity,
                                 const stereo::RectifiedGeometry& camera,
                                 const Eigen::Isometry3d& T_base_cam0);

}  // namespace epmap::ep
