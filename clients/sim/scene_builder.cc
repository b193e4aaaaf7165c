#include "clients/sim/scene_builder.h"

#include <opencv2/imgproc.hpp>

namespace epmap::sim {

int SceneBuilder::AddTexture(const cv::Mat& bgr) {
  if (scene_->channels == 1 && bgr.channels() == 3) {
    cv::Mat grey;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    scene_->textures.emplace_back(grey);
  } else {
    scene_->textures.emplace_back(bgr);
  }
  return static_cast<int>(scene_->textures.size()) - 1;
}

Quad MakePanel(const Scene& scene, const Lighting& lighting, Rng& rng,
               const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
               const Eigen::Vector3d& down, const Material& m, int object) {
  Quad q;
  q.origin = top_left;
  q.edge_u = right;
  q.edge_v = down;
  q.texture = m.texture;
  const Texture& tex = scene.textures.at(static_cast<size_t>(m.texture));
  if (m.texels_per_metre > 0) {
    q.tex_span = {right.norm() * m.texels_per_metre, down.norm() * m.texels_per_metre};
    q.tex_origin = {rng.Uniform(0, tex.width()), rng.Uniform(0, tex.height())};
  } else {
    // Stretched once: texel centres run from -0.5 to size - 0.5 across the face.
    q.tex_span = {static_cast<double>(tex.width()), static_cast<double>(tex.height())};
    q.tex_origin = {-0.5, -0.5};
  }
  q.shade = lighting.Shade(q.normal()) * m.brightness;
  q.object = object;
  return q;
}

void MakeBox(const Scene& scene, const Lighting& lighting, Rng& rng, const Eigen::Isometry3d& pose,
             const Eigen::Vector3d& size, const BoxMaterials& m, int object,
             std::vector<Quad>* into) {
  const Eigen::Matrix3d& R = pose.linear();
  const Eigen::Vector3d ex = R.col(0) * size.x(), ey = R.col(1) * size.y(),
                        ez = R.col(2) * size.z();
  const Eigen::Vector3d c = pose.translation();
  // Each face seen from outside: (outward normal, right, down); right = forward x up, where
  // the viewer looks along -normal.
  struct Face {
    Eigen::Vector3d normal_half, right, down;
  };
  const Face faces[6] = {
      {ex / 2, ey, -ez},    // +x: right = +y, down = -z
      {-ex / 2, -ey, -ez},  // -x
      {ey / 2, -ex, -ez},   // +y
      {-ey / 2, ex, -ez},   // -y
      {ez / 2, -ey, -ex},   // top, image up = +x
      {-ez / 2, ey, -ex},   // bottom
  };
  for (int i = 0; i < 6; ++i) {
    const Face& f = faces[i];
    const Eigen::Vector3d top_left = c + f.normal_half - f.right / 2 - f.down / 2;
    into->push_back(MakePanel(scene, lighting, rng, top_left, f.right, f.down,
                              m[static_cast<size_t>(i)], object));
  }
}

void SceneBuilder::AddBlock(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                            const BoxMaterials& m) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = (lo + hi) / 2;
  AddBox(pose, hi - lo, m);
}

}  // namespace epmap::sim
