#pragma once
// Renders one stereo pair of a world with everything the ground truth needs, shared by the
// image scenarios: exposure of both images (same illumination gain, independent noise), depth
// of both cameras, disparity of a rectified pair, and the mask of independently moving things.

#include <Eigen/Geometry>
#include <vector>

#include "clients/sim/renderer.h"
#include "clients/sim/scenario.h"
#include "clients/sim/sensor.h"

namespace epmap::sim {

struct StereoShot {
  const Scene* scene = nullptr;
  std::vector<Quad> moving;  // faces of things that move on their own (Quad::object > 0)
  PinholeCamera camera;      // both cameras share the intrinsics
  Eigen::Isometry3d T_world_cam0 = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_world_cam1 = Eigen::Isometry3d::Identity();
  double gain = 1.0;  // illumination (flicker), the same for both cameras
  SensorModel sensor;
  uint64_t seed = 1;  // image noise is drawn from (seed, frame index, camera)
  int index = 0;
  bool ground_truth = true;  // false: images and poses only
  // Rectified rig: cam1 = cam0 shifted by `baseline` along cam0's x; fills gt_disparity.
  bool rectified = false;
  double baseline = 0;
  // Odd k >= 1: each pixel's light is the mean of k x k samples spread over its area, as a
  // sensor integrates it, so a silhouette (a wall's end, a door jamb, the floor line) lands
  // between pixels with its sub-pixel position in the grey levels; with 1 sample per pixel it
  // snaps to the pixel grid, which at a few pixels of disparity is metres of depth. The ground
  // truth stays the exact value at the pixel centre (the middle sample, as k is odd).
  int supersample = 1;
};

// Fills frame->left, right, gt_T_world_cam0/1, gt_T_cam0_cam1 and, with ground_truth,
// gt_depth, gt_depth_right, gt_unexpected and (rectified rigs) gt_disparity.
void ShootStereo(const StereoShot& shot, SimFrame* frame);

}  // namespace epmap::sim
