#pragma once
// A small CPU renderer of textured planar faces with a z-buffer, exact by construction: for a
// plane seen by a pinhole camera, inverse depth is affine in the pixel coordinates and texture
// coordinates follow a homography, so each face is scanned row by row over its exact projected
// outline, and the depth buffer that decides visibility is the ground truth itself.
//
// Pass 1 rasterises every face (after near-plane clipping) into an inverse-depth buffer;
// pass 2 shades each pixel once, sampling the winning face's texture with trilinear filtering
// at the pixel's footprint (from the homography's derivatives).

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

#include "clients/sim/texture.h"
#include "common/dataset/dataset.h"

namespace epmap::sim {

// Pixel (u, v) = (fx X/Z + cx, fy Y/Z + cy) in the optical frame (x right, y down, z forward);
// integer coordinates are pixel centres.
struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

// The sensor.yaml the camera at `T_base_cam` is written with.
inline dataset::CameraSensor SensorDescription(const PinholeCamera& c,
                                               const Eigen::Isometry3d& T_base_cam,
                                               double rate_hz) {
  return dataset::RectifiedPinholeSensor(c.width, c.height, c.fx, c.fy, c.cx, c.cy, T_base_cam,
                                         rate_hz);
}

// A textured parallelogram: the points origin + a * edge_u + b * edge_v, a and b in [0, 1].
// Its front side is the one from which edge_u points right and edge_v points down, as the
// x and y axes of an image do: the front normal is edge_v x edge_u.
struct Quad {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d edge_u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d edge_v = Eigen::Vector3d::UnitY();
  int texture = 0;                   // index into Scene::textures
  Eigen::Vector2d tex_origin{0, 0};  // texel coordinates (s, t) at `origin`
  Eigen::Vector2d tex_span{1, 1};    // texels covered along edge_u and edge_v
  float shade = 1.0F;                // lighting factor applied to the texture
  int object = 0;                    // 0 = static world, > 0 = moves on its own
  bool two_sided = false;            // else invisible from behind

  Eigen::Vector3d normal() const { return edge_v.cross(edge_u).normalized(); }
};

struct Scene {
  int channels = 3;  // 3 = BGR, 1 = grey; every texture has this many channels
  std::vector<Texture> textures;
  std::vector<Quad> quads;  // the static world
};

struct RenderOutput {
  cv::Mat radiance;   // CV_32FC(channels), 0..255, before optics and sensor
  cv::Mat inv_depth;  // CV_32FC1, 1/z in 1/m (z along the optical axis), 0 = nothing seen
  cv::Mat object;     // CV_8UC1, Quad::object of the visible face (0 = static or nothing)
  cv::Mat face;       // CV_32SC1 scratch: index of the visible face (-1 = none)
};

// Renders `scene.quads` plus `moving` (faces of objects that move on their own, same textures)
// as seen by `camera` placed at T_world_cam. Buffers in *out are reused when their size fits.
// Pixels that see nothing get radiance `background` and inverse depth 0.
void Render(const Scene& scene, const std::vector<Quad>& moving, const PinholeCamera& camera,
            const Eigen::Isometry3d& T_world_cam, RenderOutput* out, float background = 128.0F);

}  // namespace epmap::sim
