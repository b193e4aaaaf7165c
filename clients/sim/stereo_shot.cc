#include "clients/sim/stereo_shot.h"

#include <limits>

namespace epmap::sim {

namespace {

// z = 1 / (1/z); NaN where nothing was seen.
cv::Mat DepthFromInverse(const cv::Mat& inv_depth) {
  cv::Mat depth(inv_depth.size(), CV_32FC1);
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  for (int y = 0; y < inv_depth.rows; ++y) {
    const float* iz = inv_depth.ptr<float>(y);
    float* z = depth.ptr<float>(y);
    for (int x = 0; x < inv_depth.cols; ++x) z[x] = iz[x] > 0 ? 1.0F / iz[x] : kNaN;
  }
  return depth;
}

}  // namespace

void ShootStereo(const StereoShot& shot, SimFrame* frame) {
  // Render buffers are reused by the next frame on this thread: fresh multi-megabyte buffers
  // cost page faults that were ~10% of a frame.
  thread_local RenderOutput out0, out1;
  Render(*shot.scene, shot.moving, shot.camera, shot.T_world_cam0, &out0);
  Render(*shot.scene, shot.moving, shot.camera, shot.T_world_cam1, &out1);
  const uint64_t i = static_cast<uint64_t>(shot.index);
  frame->left =
      Expose(out0.radiance, shot.gain, shot.sensor, Rng(shot.seed, Stream::kImageNoise, 2 * i));
  frame->right =
      Expose(out1.radiance, shot.gain, shot.sensor, Rng(shot.seed, Stream::kImageNoise, 2 * i + 1));
  frame->gt_T_world_cam0 = shot.T_world_cam0;
  frame->gt_T_world_cam1 = shot.T_world_cam1;
  frame->gt_T_cam0_cam1 = shot.T_world_cam0.inverse() * shot.T_world_cam1;
  if (!shot.ground_truth) return;
  frame->gt_depth = DepthFromInverse(out0.inv_depth);
  frame->gt_depth_right = DepthFromInverse(out1.inv_depth);
  frame->gt_unexpected = out0.object > 0;  // 255 where a moving object is seen
  if (shot.rectified) {
    // d = fx * B / z: the inverse depth buffer scaled.
    constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
    const double fb = shot.camera.fx * shot.baseline;
    frame->gt_disparity.create(out0.inv_depth.size(), CV_32FC1);
    for (int y = 0; y < out0.inv_depth.rows; ++y) {
      const float* iz = out0.inv_depth.ptr<float>(y);
      float* d = frame->gt_disparity.ptr<float>(y);
      for (int x = 0; x < out0.inv_depth.cols; ++x) {
        d[x] = iz[x] > 0 ? static_cast<float>(fb * iz[x]) : kNaN;
      }
    }
  } else {
    frame->gt_disparity.release();
  }
}

}  // namespace epmap::sim
