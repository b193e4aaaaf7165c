#pragma once
// A small ray-cast world for the EP tests: textured rectangles (a back wall, a box face, a floor
// and an optional moving square) seen by a rectified stereo pair. Gives the left and right
// images and the true disparity of the left camera, so that the tests know exactly what the
// EP pipeline should predict. Written for these tests; the project's simulator is clients/sim.

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "perception/stereo/rectification.h"

namespace epmap::testing {

struct TexturedRect {
  Eigen::Vector3d origin;  // a corner, world frame
  Eigen::Vector3d axis_s;  // unit vector along the first side
  Eigen::Vector3d axis_t;  // unit vector along the second side
  double size_s = 1, size_t_ = 1;
  int texture = 0;  // which texture
  double brightness = 1.0;
};

class SyntheticScene {
 public:
  explicit SyntheticScene(int width = 320, int height = 240, uint64_t seed = 5) {
    camera_.width = width;
    camera_.height = height;
    camera_.fx = camera_.fy = 0.8 * width;
    camera_.cx = (width - 1) / 2.0;
    camera_.cy = (height - 1) / 2.0;
    camera_.baseline_m = 0.068;
    std::mt19937_64 rng(seed);
    for (int i = 0; i < 3; ++i) textures_.push_back(MakeTexture(rng));
    // World frame = the first camera's optical frame (x right, y down, z forward).
    rects_.push_back({{-4, -3, 4.0}, {1, 0, 0}, {0, 1, 0}, 8, 6, 0, 1.0});          // back wall
    rects_.push_back({{-0.9, -0.4, 2.2}, {1, 0, 0}, {0, 1, 0}, 0.8, 1.2, 1, 0.9});  // box face
    rects_.push_back({{-4, 0.8, 0.5}, {1, 0, 0}, {0, 0, 1}, 8, 3.5, 2, 0.8});       // floor
  }

  const stereo::RectifiedGeometry& camera() const { return camera_; }

  // The moving square (0.2 m, texture 1 brightened), centred at `centre` facing the camera.
  void SetMovingSquare(const Eigen::Vector3d& centre, double size = 0.2) {
    square_ = TexturedRect{
        centre - Eigen::Vector3d(size / 2, size / 2, 0), {1, 0, 0}, {0, 1, 0}, size, size, 2, 1.3};
    has_square_ = true;
  }
  void RemoveMovingSquare() { has_square_ = false; }

  // Renders the rectified pair for T_world_cam0 (the left camera; the right one is `baseline`
  // along the left camera's x axis). Outputs CV_8U images, CV_32F true disparity and the true
  // mask of the moving square (CV_8U 255).
  void Render(const Eigen::Isometry3d& T_world_cam0, cv::Mat* left, cv::Mat* right,
              cv::Mat* disparity = nullptr, cv::Mat* square_mask = nullptr) const {
    cv::Mat depth, mask;
    *left = RenderView(T_world_cam0, &depth, &mask);
    Eigen::Isometry3d T_world_cam1 = T_world_cam0;
    T_world_cam1.translate(Eigen::Vector3d(camera_.baseline_m, 0, 0));
    *right = RenderView(T_world_cam1, nullptr, nullptr);
    if (disparity) {
      *disparity = cv::Mat(depth.size(), CV_32F);
      for (int v = 0; v < depth.rows; ++v) {
        for (int u = 0; u < depth.cols; ++u) {
          const float z = depth.at<float>(v, u);
          disparity->at<float>(v, u) = z > 0
                                           ? static_cast<float>(camera_.fx * camera_.baseline_m / z)
                                           : std::numeric_limits<float>::quiet_NaN();
        }
      }
    }
    if (square_mask) *square_mask = mask;
  }

 private:
  static cv::Mat MakeTexture(std::mt19937_64& rng) {
    // Multi-scale noise: good texture for block matching at every distance.
    cv::Mat tex(512, 512, CV_32F, cv::Scalar(0));
    std::normal_distribution<float> n(0.0F, 1.0F);
    for (int scale : {2, 6, 18}) {
      cv::Mat layer(512 / scale, 512 / scale, CV_32F);
      for (auto& v : cv::Mat_<float>(layer)) v = n(rng);
      cv::resize(layer, layer, tex.size(), 0, 0, cv::INTER_CUBIC);
      tex += layer * (scale == 2 ? 25.0 : 30.0);
    }
    tex += 128.0;
    return tex;
  }

  static float Sample(const cv::Mat& tex, double s, double t) {
    // 15 mm per texel, wrapping: the finest detail spans about two pixels at 4 m (no aliasing
    // that a prediction could not reproduce).
    const double x = s / 0.015, y = t / 0.015;
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    const auto at = [&](int xx, int yy) {
      return tex.at<float>(((yy % tex.rows) + tex.rows) % tex.rows,
                           ((xx % tex.cols) + tex.cols) % tex.cols);
    };
    return static_cast<float>((at(x0, y0) * (1 - fx) + at(x0 + 1, y0) * fx) * (1 - fy) +
                              (at(x0, y0 + 1) * (1 - fx) + at(x0 + 1, y0 + 1) * fx) * fy);
  }

  cv::Mat RenderView(const Eigen::Isometry3d& T_world_cam, cv::Mat* depth, cv::Mat* mask) const {
    const int W = camera_.width, H = camera_.height;
    cv::Mat image(H, W, CV_8U);
    if (depth) *depth = cv::Mat(H, W, CV_32F, cv::Scalar(0));
    if (mask) *mask = cv::Mat(H, W, CV_8U, cv::Scalar(0));
    const Eigen::Matrix3d R = T_world_cam.linear();
    const Eigen::Vector3d o = T_world_cam.translation();
    std::vector<const TexturedRect*> rects;
    for (const auto& r : rects_) rects.push_back(&r);
    if (has_square_) rects.push_back(&square_);
    for (int v = 0; v < H; ++v) {
      for (int u = 0; u < W; ++u) {
        // Ray with camera-frame z = 1, so the hit distance along it is the depth z.
        const Eigen::Vector3d d =
            R * Eigen::Vector3d((u - camera_.cx) / camera_.fx, (v - camera_.cy) / camera_.fy, 1.0);
        double best = 1e30;
        float value = 0;
        bool square = false;
        for (const TexturedRect* r : rects) {
          const Eigen::Vector3d n = r->axis_s.cross(r->axis_t);
          const double denom = n.dot(d);
          if (std::abs(denom) < 1e-12) continue;
          const double z = n.dot(r->origin - o) / denom;
          if (z <= 0.05 || z >= best) continue;
          const Eigen::Vector3d p = o + z * d - r->origin;
          const double s = p.dot(r->axis_s), t = p.dot(r->axis_t);
          if (s < 0 || t < 0 || s > r->size_s || t > r->size_t_) continue;
          best = z;
          value = static_cast<float>(r->brightness *
                                     Sample(textures_[static_cast<size_t>(r->texture)], s, t));
          square = r == &square_;
        }
        image.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(value);
        if (depth && best < 1e29) depth->at<float>(v, u) = static_cast<float>(best);
        if (mask && square) mask->at<uint8_t>(v, u) = 255;
      }
    }
    return image;
  }

  stereo::RectifiedGeometry camera_;
  std::vector<cv::Mat> textures_;
  std::vector<TexturedRect> rects_;
  TexturedRect square_;
  bool has_square_ = false;
};

// A camera pose turning about a neck point 10 cm behind and below the eye (so rotation also
// translates the camera a little, as on a robot head).
inline Eigen::Isometry3d HeadPose(double yaw, double pitch) {
  const Eigen::Vector3d neck(0.0, 0.08, -0.10);  // in the world = initial camera frame
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translate(neck);
  T.rotate(Eigen::AngleAxisd(yaw, -Eigen::Vector3d::UnitY()) *
           Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()));
  T.translate(-neck);
  return T;  // T_world_cam0
}

}  // namespace epmap::testing
