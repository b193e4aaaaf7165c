#pragma once
// Helpers that furnish a Scene: textured panels and boxes with Lambertian shading from one
// distant light, so that faces of different orientation differ in brightness as in a room.

#include <Eigen/Geometry>
#include <array>
#include <opencv2/core.hpp>
#include <vector>

#include "clients/sim/random.h"
#include "clients/sim/renderer.h"

namespace epmap::sim {

struct Material {
  int texture = 0;
  // > 0: the texture repeats over the face at this density (texels per metre), from a random
  // offset; 0: the whole texture is stretched over the face once (posters, book rows).
  double texels_per_metre = 0;
  float brightness = 1.0F;  // albedo multiplier
};

struct Lighting {
  Eigen::Vector3d towards_light = Eigen::Vector3d(-0.3, 0.35, 0.89).normalized();
  double ambient = 0.62;
  double diffuse = 0.38;
  float Shade(const Eigen::Vector3d& normal) const {
    return static_cast<float>(ambient + diffuse * std::max(0.0, normal.dot(towards_light)));
  }
};

// Box faces in the order +x, -x, +y, -y, +z (top), -z (bottom) of the box's own frame.
using BoxMaterials = std::array<Material, 6>;
inline BoxMaterials SameMaterial(const Material& m) {
  return {m, m, m, m, m, m};
}

// A one-sided panel top_left + a * right + b * down (a, b in [0, 1]), seen from the side where
// `right` points right and `down` points down. `rng` draws the offset of a repeating texture.
Quad MakePanel(const Scene& scene, const Lighting& lighting, Rng& rng,
               const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
               const Eigen::Vector3d& down, const Material& material, int object = 0);

// A closed box of full size `size` centred at `pose` (its local z is the box's up); appends
// its six faces to *into.
void MakeBox(const Scene& scene, const Lighting& lighting, Rng& rng, const Eigen::Isometry3d& pose,
             const Eigen::Vector3d& size, const BoxMaterials& materials, int object,
             std::vector<Quad>* into);

class SceneBuilder {
 public:
  // `rng` draws the texture offsets of repeating materials.
  SceneBuilder(Scene* scene, Rng rng, Lighting lighting = {})
      : scene_(scene), rng_(rng), lighting_(lighting) {}

  // Adds a texture (converted to grey when the scene is grey); returns its index.
  int AddTexture(const cv::Mat& bgr);

  void AddPanel(const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
                const Eigen::Vector3d& down, const Material& material) {
    scene_->quads.push_back(MakePanel(*scene_, lighting_, rng_, top_left, right, down, material));
  }
  void AddBox(const Eigen::Isometry3d& pose, const Eigen::Vector3d& size, const BoxMaterials& m) {
    MakeBox(*scene_, lighting_, rng_, pose, size, m, 0, &scene_->quads);
  }
  // An axis-aligned box from its minimum and maximum corners (world frame).
  void AddBlock(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const BoxMaterials& m);

  Scene& scene() { return *scene_; }
  const Lighting& lighting() const { return lighting_; }

 private:
  Scene* scene_;
  Rng rng_;
  Lighting lighting_;
};

}  // namespace epmap::sim
