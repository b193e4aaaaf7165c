#include "clients/sim/stereo_shot.h"

#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

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

// The camera whose pixels are the k x k sub-pixels of `c`'s: coarse pixel u spans
// [u - 0.5, u + 0.5], so fine pixel k u + j has its centre at u - 0.5 + (j + 0.5) / k.
PinholeCamera SubPixelCamera(const PinholeCamera& c, int k) {
  PinholeCamera fine = c;
  fine.width = c.width * k;
  fine.height = c.height * k;
  fine.fx = c.fx * k;
  fine.fy = c.fy * k;
  fine.cx = c.cx * k + 0.5 * (k - 1);
  fine.cy = c.cy * k + 0.5 * (k - 1);
  return fine;
}

// Renders at `k` x `k` samples per pixel (odd k): radiance is their mean (a pixel integrates
// the light over its area), inverse depth and object are the middle sample's, i.e. the exact
// values at the pixel centre. k = 1 renders straight into *out.
void RenderOverPixelArea(const StereoShot& shot, const Eigen::Isometry3d& T_world_cam, int k,
                         RenderOutput* fine, RenderOutput* out) {
  if (k == 1) {
    Render(*shot.scene, shot.moving, shot.camera, T_world_cam, out);
    return;
  }
  Render(*shot.scene, shot.moving, SubPixelCamera(shot.camera, k), T_world_cam, fine);
  // INTER_AREA with an integer factor is the exact k x k box mean.
  cv::resize(fine->radiance, out->radiance, cv::Size(shot.camera.width, shot.camera.height), 0, 0,
             cv::INTER_AREA);
  out->inv_depth.create(shot.camera.height, shot.camera.width, CV_32FC1);
  out->object.create(shot.camera.height, shot.camera.width, CV_8UC1);
  const int mid = k / 2;
  for (int y = 0; y < shot.camera.height; ++y) {
    const float* fine_iz = fine->inv_depth.ptr<float>(k * y + mid);
    const uint8_t* fine_obj = fine->object.ptr<uint8_t>(k * y + mid);
    float* iz = out->inv_depth.ptr<float>(y);
    uint8_t* obj = out->object.ptr<uint8_t>(y);
    for (int x = 0; x < shot.camera.width; ++x) {
      iz[x] = fine_iz[k * x + mid];
      obj[x] = fine_obj[k * x + mid];
    }
  }
}

}  // namespace

void ShootStereo(const StereoShot& shot, SimFrame* frame) {
  // Render buffers are reused by the next frame on this thread: fresh multi-megabyte buffers
  // cost page faults that were ~10% of a frame.
  thread_local RenderOutput out0, out1, fine;
  if (shot.supersample < 1 || shot.supersample % 2 == 0) {
    throw std::invalid_argument("StereoShot::supersample must be odd and >= 1");
  }
  RenderOverPixelArea(shot, shot.T_world_cam0, shot.supersample, &fine, &out0);
  RenderOverPixelArea(shot, shot.T_world_cam1, shot.supersample, &fine, &out1);
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
