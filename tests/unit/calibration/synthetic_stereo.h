#pragma once
// Synthetic stereo scenes for the unit tests (the vergence scenario comes from clients/sim):
// textured planar quads rendered into two pinhole cameras with OpenCV (painter's algorithm,
// one perspective warp per quad), so that SIFT, matching, RANSAC and rectification run on
// real pixels with known geometry.

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace epmap::calibration::testing {

struct TexturedQuad {
  std::array<Eigen::Vector3d, 4> corners;  // in the world frame, in texture order TL TR BR BL
  cv::Mat texture;                         // CV_8UC1
};

// A random blob-and-stripe texture that SIFT finds plenty of distinctive keypoints on.
inline cv::Mat MakeTexture(int size, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat t(size, size, CV_8UC1, cv::Scalar(rng.uniform(60, 200)));
  for (int i = 0; i < size * size / 300; ++i) {
    const cv::Point c(rng.uniform(0, size), rng.uniform(0, size));
    const int r = rng.uniform(2, size / 24);
    const cv::Scalar v(rng.uniform(0, 256));
    switch (rng.uniform(0, 3)) {
      case 0:
        cv::circle(t, c, r, v, cv::FILLED, cv::LINE_AA);
        break;
      case 1:
        cv::rectangle(t, c, c + cv::Point(r, rng.uniform(2, size / 24)), v, cv::FILLED);
        break;
      default:
        cv::ellipse(t, c, cv::Size(r, r / 2 + 1), rng.uniform(0, 180), 0, 360, v, cv::FILLED,
                    cv::LINE_AA);
    }
  }
  cv::GaussianBlur(t, t, cv::Size(3, 3), 0.8);
  return t;
}

// A quad facing the camera (normal rotated by `yaw` about y) centred at `centre`.
inline TexturedQuad MakeQuad(const Eigen::Vector3d& centre, double width, double height, double yaw,
                             uint64_t seed) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d ex = r * Eigen::Vector3d::UnitX() * (width / 2);
  const Eigen::Vector3d ey = Eigen::Vector3d::UnitY() * (height / 2);
  TexturedQuad q;
  q.corners = {centre - ex - ey, centre + ex - ey, centre + ex + ey, centre - ex + ey};
  q.texture = MakeTexture(512, seed);
  return q;
}

// Renders the quads seen by a pinhole camera with pose T_world_cam (z forward, y down).
inline cv::Mat Render(const std::vector<TexturedQuad>& quads, const Eigen::Matrix3d& k,
                      const Eigen::Isometry3d& T_world_cam, cv::Size size, int background = 128) {
  cv::Mat img(size, CV_8UC1, cv::Scalar(background));
  const Eigen::Isometry3d T_cam_world = T_world_cam.inverse();
  std::vector<size_t> order(quads.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  const auto depth = [&](size_t i) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& p : quads[i].corners) c += p / 4;
    return (T_cam_world * c).z();
  };
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return depth(a) > depth(b); });
  for (size_t i : order) {
    const auto& q = quads[i];
    std::vector<cv::Point2f> dst, src;
    bool visible = true;
    for (const auto& p : q.corners) {
      const Eigen::Vector3d pc = T_cam_world * p;
      if (pc.z() <= 0.05) visible = false;
      const Eigen::Vector3d px = k * pc;
      dst.emplace_back(static_cast<float>(px.x() / px.z()), static_cast<float>(px.y() / px.z()));
    }
    if (!visible) continue;
    const auto w = static_cast<float>(q.texture.cols), h = static_cast<float>(q.texture.rows);
    src = {{0, 0}, {w, 0}, {w, h}, {0, h}};
    const cv::Mat hm = cv::getPerspectiveTransform(src, dst);
    cv::Mat layer, mask;
    cv::warpPerspective(q.texture, layer, hm, size, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    cv::warpPerspective(cv::Mat(q.texture.size(), CV_8UC1, cv::Scalar(255)), mask, hm, size,
                        cv::INTER_NEAREST, cv::BORDER_CONSTANT);
    layer.copyTo(img, mask);
  }
  return img;
}

// A scene with depth: a textured wall and boxes at several distances and angles.
inline std::vector<TexturedQuad> MakeDepthScene(uint64_t seed) {
  return {MakeQuad({0.0, 0.0, 2.5}, 4.0, 3.0, 0.0, seed),
          MakeQuad({-0.35, 0.05, 0.9}, 0.45, 0.45, 0.5, seed + 1),
          MakeQuad({0.30, -0.15, 0.7}, 0.35, 0.30, -0.6, seed + 2),
          MakeQuad({0.10, 0.30, 1.3}, 0.6, 0.35, 0.3, seed + 3),
          MakeQuad({-0.15, -0.35, 1.6}, 0.7, 0.4, -0.2, seed + 4)};
}

// One fronto-parallel textured plane filling the view.
inline std::vector<TexturedQuad> MakePlanarScene(uint64_t seed) {
  return {MakeQuad({0.0, 0.0, 1.2}, 3.0, 2.4, 0.15, seed)};
}

}  // namespace epmap::calibration::testing
