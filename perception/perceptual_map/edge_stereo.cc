#include "perception/perceptual_map/edge_stereo.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace epmap::perceptual_map {

void ValidateCamera(const StereoCamera& c) {
  const double fx = c.fx, fy = c.fy, cx = c.cx, cy = c.cy, baseline_m = c.baseline_m;
  if (!(fx > 0) || !(fy > 0) || !std::isfinite(fx) || !std::isfinite(fy)) {
    throw std::invalid_argument("stereo camera: focal lengths must be positive and finite");
  }
  if (!std::isfinite(cx) || !std::isfinite(cy)) {
    throw std::invalid_argument("stereo camera: principal point must be finite");
  }
  if (!(baseline_m > 0) || !std::isfinite(baseline_m)) {
    throw std::invalid_argument("stereo camera: baseline must be positive, got " +
                                std::to_string(baseline_m));
  }
}

void EdgeStereoParams::Validate() const {
  if (blur_sigma_px < 0) throw std::invalid_argument("edge stereo: blur_sigma_px must be >= 0");
  if (!(min_gradient > 0)) throw std::invalid_argument("edge stereo: min_gradient must be > 0");
  if (!(max_slope > 0)) throw std::invalid_argument("edge stereo: max_slope must be > 0");
  if (!(refine_disparity_px >= 0 && refine_disparity_px <= 8)) {
    throw std::invalid_argument("edge stereo: refine_disparity_px must be in [0, 8]");
  }
  if (!(min_disparity_px > 0) || !(max_disparity_px > min_disparity_px)) {
    throw std::invalid_argument("edge stereo: need 0 < min_disparity_px < max_disparity_px");
  }
  if (window_half_width < 1 || window_half_height < 0) {
    throw std::invalid_argument("edge stereo: window half sizes must be >= 1 and >= 0");
  }
  if (!(uniqueness > 0 && uniqueness <= 1)) {
    throw std::invalid_argument("edge stereo: uniqueness must be in (0, 1]");
  }
  if (!(max_gradient_ratio >= 1)) {
    throw std::invalid_argument("edge stereo: max_gradient_ratio must be >= 1");
  }
  if (!(max_range_m > 0)) throw std::invalid_argument("edge stereo: max_range_m must be > 0");
}

Eigen::Vector3d Triangulate(const StereoCamera& c, double u, double v, double disparity) {
  const double z = c.baseline_m * c.fx / disparity;        // Eq. 1: z = b f / d
  const double x = (u - c.cx) * c.baseline_m / disparity;  // Eq. 2: x = (c - c0) b / d
  const double y = (v - c.cy) * z / c.fy;                  // the row, for the height
  return {x, y, z};
}

namespace {

cv::Mat ToSmoothedFloat(const cv::Mat& image, double sigma) {
  cv::Mat grey;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  } else {
    grey = image;
  }
  cv::Mat f;
  grey.convertTo(f, CV_32F, grey.depth() == CV_16U ? 1.0 / 256.0 : 1.0);
  if (sigma > 0) cv::GaussianBlur(f, f, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  return f;
}

// Where the vertex of the parabola through (-1, a), (0, m), (+1, b) lies, for m the extreme
// of the three (a maximum or a minimum); 0 when they are collinear.
float ParabolaVertex(float a, float m, float b) {
  const float denom = a - 2.0F * m + b;
  return denom != 0 ? std::clamp(0.5F * (a - b) / denom, -0.5F, 0.5F) : 0.0F;
}

std::vector<std::vector<RowEdge>> RowEdgesOfSmoothed(const cv::Mat& f, const EdgeStereoParams& p) {
  cv::Mat gx, gy;
  // Sobel 3x3 divided by 8: grey levels per pixel.
  cv::Sobel(f, gx, CV_32F, 1, 0, 3, 1.0 / 8.0, 0, cv::BORDER_REPLICATE);
  cv::Sobel(f, gy, CV_32F, 0, 1, 3, 1.0 / 8.0, 0, cv::BORDER_REPLICATE);
  std::vector<std::vector<RowEdge>> rows(static_cast<size_t>(f.rows));
  const float min_g = static_cast<float>(p.min_gradient);
  const float slope = static_cast<float>(p.max_slope);
  for (int r = 1; r + 1 < f.rows; ++r) {
    const float* x = gx.ptr<float>(r);
    const float* y = gy.ptr<float>(r);
    auto& out = rows[static_cast<size_t>(r)];
    for (int c = 1; c + 1 < f.cols; ++c) {
      const float m = std::abs(x[c]);
      if (m < min_g || std::abs(y[c]) > slope * m) continue;
      const float a = std::abs(x[c - 1]);
      const float b = std::abs(x[c + 1]);
      // A maximum of |gx| along the row (ties broken to the left so a plateau yields one point).
      if (!(m >= a && m > b)) continue;
      // Parabola through the three magnitudes: its vertex is the sub-pixel edge location.
      out.push_back({static_cast<float>(c) + ParabolaVertex(a, m, b), x[c], std::abs(y[c]) / m});
    }
  }
  return rows;
}

// Linear interpolation of row r of f at column u (u inside [0, cols-1]).
inline float Sample(const float* row, float u) {
  const int i = static_cast<int>(u);
  const float w = u - static_cast<float>(i);
  return row[i] * (1.0F - w) + row[i + 1] * w;
}

// The disparity within +-p.refine_disparity_px of `d` that minimises the sum of squared
// differences between the left window around (u, r) and the right image sampled at x - d:
// a scan at 1/20 px, then the vertex of the parabola through the best step and its neighbours.
float RefineDisparity(const cv::Mat& fl, const cv::Mat& fr, float u, int r, float d,
                      const EdgeStereoParams& p) {
  const int ww = p.window_half_width, wh = p.window_half_height;
  const int cl = static_cast<int>(std::lround(u));
  const float last_column = static_cast<float>(fr.cols - 1);
  constexpr float kStep = 0.05F;
  constexpr int kMaxSteps = 160;  // Validate() bounds refine_disparity_px by 8 px = 160 steps
  const int steps = std::min(kMaxSteps, static_cast<int>(std::ceil(p.refine_disparity_px / kStep)));
  auto ssd = [&](float disparity) {
    float sum = 0;
    for (int dy = -wh; dy <= wh; ++dy) {
      const float* lrow = fl.ptr<float>(r + dy);
      const float* rrow = fr.ptr<float>(r + dy);
      for (int dx = -ww; dx <= ww; ++dx) {
        const float xr = static_cast<float>(cl + dx) - disparity;
        if (xr < 0 || xr >= last_column) return std::numeric_limits<float>::infinity();
        const float diff = lrow[cl + dx] - Sample(rrow, xr);
        sum += diff * diff;
      }
    }
    return sum;
  };
  std::array<float, 2 * kMaxSteps + 1> cost;  // on the stack: this runs per matched point
  const size_t n = static_cast<size_t>(2 * steps + 1);
  size_t best = 0;
  for (size_t i = 0; i < n; ++i) {
    cost[i] = ssd(d + kStep * (static_cast<float>(i) - static_cast<float>(steps)));
    if (cost[i] < cost[best]) best = i;
  }
  if (best == 0 || best + 1 == n) return d;  // no minimum inside: keep the edges'
  const float a = cost[best - 1], b = cost[best + 1];
  if (!std::isfinite(a) || !std::isfinite(b)) return d;  // the window left the image
  return d + kStep * (static_cast<float>(best) - static_cast<float>(steps) +
                      ParabolaVertex(a, cost[best], b));
}

}  // namespace

std::vector<std::vector<RowEdge>> DetectRowEdges(const cv::Mat& grey, const EdgeStereoParams& p) {
  if (grey.empty()) throw std::invalid_argument("DetectRowEdges: empty image");
  p.Validate();
  return RowEdgesOfSmoothed(ToSmoothedFloat(grey, p.blur_sigma_px), p);
}

std::vector<EdgePoint> MatchEdgePoints(const cv::Mat& left, const cv::Mat& right,
                                       const StereoCamera& camera, const EdgeStereoParams& p,
                                       EdgeStereoStats* stats) {
  if (left.empty() || right.empty()) throw std::invalid_argument("MatchEdgePoints: empty image");
  if (left.size() != right.size() || left.type() != right.type()) {
    throw std::invalid_argument("MatchEdgePoints: left and right differ in size or type");
  }
  ValidateCamera(camera);
  p.Validate();
  const cv::Mat fl = ToSmoothedFloat(left, p.blur_sigma_px);
  const cv::Mat fr = ToSmoothedFloat(right, p.blur_sigma_px);
  const auto left_rows = RowEdgesOfSmoothed(fl, p);
  const auto right_rows = RowEdgesOfSmoothed(fr, p);

  EdgeStereoStats s;
  std::vector<EdgePoint> points;
  const int ww = p.window_half_width;
  const int wh = p.window_half_height;
  const float lo_u = static_cast<float>(ww + 1);
  const float hi_u = static_cast<float>(fl.cols - ww - 2);
  const float dmin = static_cast<float>(p.min_disparity_px);
  const float dmax = static_cast<float>(p.max_disparity_px);
  const float ratio = static_cast<float>(p.max_gradient_ratio);
  const float inf = std::numeric_limits<float>::infinity();
  const float window_pixels = static_cast<float>((2 * ww + 1) * (2 * wh + 1));

  std::vector<float> cost;
  std::vector<int> claims;
  for (int r = 0; r < fl.rows; ++r) {
    const auto& L = left_rows[static_cast<size_t>(r)];
    const auto& R = right_rows[static_cast<size_t>(r)];
    s.left_edges += L.size();
    s.right_edges += R.size();
    if (r < wh || r + wh >= fl.rows || L.empty() || R.empty()) continue;
    // Cost matrix of every compatible (left, right) pair on this row: mean absolute grey
    // difference over the window, the right image sampled at the sub-pixel disparity.
    cost.assign(L.size() * R.size(), inf);
    for (size_t i = 0; i < L.size(); ++i) {
      const float ul = L[i].u;
      if (ul < lo_u || ul > hi_u) continue;
      for (size_t j = 0; j < R.size(); ++j) {
        const float d = ul - R[j].u;
        if (d < dmin || d > dmax) continue;
        if ((L[i].gx > 0) != (R[j].gx > 0)) continue;
        const float gl = std::abs(L[i].gx);
        const float gr = std::abs(R[j].gx);
        if (gl > ratio * gr || gr > ratio * gl) continue;
        if (R[j].u < lo_u || R[j].u > hi_u) continue;
        float sum = 0;
        const int cl = static_cast<int>(std::lround(ul));
        for (int dy = -wh; dy <= wh; ++dy) {
          const float* lrow = fl.ptr<float>(r + dy);
          const float* rrow = fr.ptr<float>(r + dy);
          for (int dx = -ww; dx <= ww; ++dx) {
            const int x = cl + dx;
            sum += std::abs(lrow[x] - Sample(rrow, static_cast<float>(x) - d));
          }
        }
        cost[i * R.size() + j] = sum / window_pixels;
      }
    }
    // Best right for each left (with the second best for the uniqueness test), best left for
    // each right (mutual check).
    std::vector<int> best_left_of_right(R.size(), -1);
    if (p.left_right_check) {
      for (size_t j = 0; j < R.size(); ++j) {
        float b = inf;
        for (size_t i = 0; i < L.size(); ++i) {
          if (cost[i * R.size() + j] < b) {
            b = cost[i * R.size() + j];
            best_left_of_right[j] = static_cast<int>(i);
          }
        }
      }
    }
    // How many left edges pick each right edge as their best acceptable match (only when asked:
    // this runs for every row of every key frame).
    claims.clear();
    if (p.reject_contested) {
      claims.assign(R.size(), 0);
      for (size_t i = 0; i < L.size(); ++i) {
        const float* row_cost = &cost[i * R.size()];
        const auto best = std::min_element(row_cost, row_cost + R.size());
        if (*best <= p.max_mean_abs_diff) ++claims[static_cast<size_t>(best - row_cost)];
      }
    }
    for (size_t i = 0; i < L.size(); ++i) {
      float b1 = inf, b2 = inf;
      int j1 = -1;
      for (size_t j = 0; j < R.size(); ++j) {
        const float c = cost[i * R.size() + j];
        if (c < b1) {
          b2 = b1;
          b1 = c;
          j1 = static_cast<int>(j);
        } else if (c < b2) {
          b2 = c;
        }
      }
      if (j1 < 0) continue;  // no compatible candidate at all
      const bool weak = b1 > p.max_mean_abs_diff ||
                        (b2 < inf && b1 > static_cast<float>(p.uniqueness) * b2) ||
                        (p.left_right_check &&
                         best_left_of_right[static_cast<size_t>(j1)] != static_cast<int>(i)) ||
                        (p.reject_contested && claims[static_cast<size_t>(j1)] > 1);
      if (weak) {
        ++s.rejected_weak;
        continue;
      }
      float d = L[i].u - R[static_cast<size_t>(j1)].u;
      if (p.refine_disparity_px > 0) d = RefineDisparity(fl, fr, L[i].u, r, d, p);
      EdgePoint e;
      e.u = L[i].u;
      e.v = static_cast<float>(r);
      e.disparity = d;
      e.slope = L[i].slope;
      e.p_cam = Triangulate(camera, e.u, e.v, d);
      if (e.p_cam.norm() > p.max_range_m) {
        ++s.rejected_range;
        continue;
      }
      points.push_back(e);
    }
  }
  s.matched = points.size();
  if (stats) *stats = s;
  return points;
}

}  // namespace epmap::perceptual_map
