#include "perception/perceptual_map/reference_objects.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>
#include <utility>

namespace epmap::perceptual_map {

void ClusteringParams::Validate() const {
  if (!(cell_size_m > 0)) throw std::invalid_argument("clustering: cell_size_m must be > 0");
  if (min_points < 2) throw std::invalid_argument("clustering: min_points must be >= 2");
  if (!(min_length_m >= 0)) throw std::invalid_argument("clustering: min_length_m must be >= 0");
  if (!(max_rms_m > 0)) throw std::invalid_argument("clustering: max_rms_m must be > 0");
  if (!(max_rms_growth_per_m2 >= 0) || !std::isfinite(max_rms_growth_per_m2)) {
    throw std::invalid_argument("clustering: max_rms_growth_per_m2 must be finite and >= 0");
  }
  if (!(far_from_range_m >= 0) || !(far_cell_size_m > 0)) {
    throw std::invalid_argument("clustering: far_from_range_m must be >= 0, far_cell_size_m > 0");
  }
  if (!(radial_max_angle_rad >= 0) || !(radial_min_range_m >= 0) || !(radial_min_offset_m >= 0)) {
    throw std::invalid_argument("clustering: radial filter values must be >= 0");
  }
}

bool FitLine(const std::vector<Eigen::Vector2d>& points, ReferenceObject* out) {
  if (points.size() < 2) return false;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  double sxx = 0, syy = 0, sxy = 0;
  for (const auto& p : points) {
    const Eigen::Vector2d d = p - mean;
    sxx += d.x() * d.x();
    syy += d.y() * d.y();
    sxy += d.x() * d.y();
  }
  if (sxx <= 0 && syy <= 0) return false;
  // Independent coordinate u (larger spread), dependent w = m u + b (Eq. 3-4).
  const bool x_independent = sxx >= syy;
  const double suu = x_independent ? sxx : syy;
  const double m = sxy / suu;
  const auto u_of = [&](const Eigen::Vector2d& p) { return x_independent ? p.x() : p.y(); };
  const auto w_of = [&](const Eigen::Vector2d& p) { return x_independent ? p.y() : p.x(); };
  const double b = w_of(mean) - m * u_of(mean);
  double umin = u_of(points.front()), umax = umin;
  double sq = 0;
  for (const auto& p : points) {
    umin = std::min(umin, u_of(p));
    umax = std::max(umax, u_of(p));
    const double r = (w_of(p) - (m * u_of(p) + b)) / std::sqrt(1 + m * m);
    sq += r * r;
  }
  const auto point = [&](double u) {
    const double w = m * u + b;  // Eq. 3 (first end point) and Eq. 4 (second)
    return x_independent ? Eigen::Vector2d(u, w) : Eigen::Vector2d(w, u);
  };
  out->a = point(umin);
  out->b = point(umax);
  out->point_count = static_cast<int>(points.size());
  out->rms_m = std::sqrt(sq / static_cast<double>(points.size()));
  return true;
}

std::vector<ReferenceObject> FitReferenceObjects(const std::vector<Eigen::Vector2d>& points,
                                                 const Eigen::Isometry2d& T_grid_view,
                                                 const ClusteringParams& params) {
  params.Validate();
  // Key: (far, column, row); far points go to the coarser grid of their own.
  std::map<std::tuple<bool, int64_t, int64_t>, std::vector<Eigen::Vector2d>> cells;
  for (const auto& p : points) {
    if (!p.allFinite()) continue;
    const bool far = params.far_from_range_m > 0 && p.norm() > params.far_from_range_m;
    const double cell = far ? params.far_cell_size_m : params.cell_size_m;
    const Eigen::Vector2d g = T_grid_view * p;
    const auto key = std::make_tuple(far, static_cast<int64_t>(std::floor(g.x() / cell)),
                                     static_cast<int64_t>(std::floor(g.y() / cell)));
    cells[key].push_back(p);
  }
  std::vector<ReferenceObject> objects;
  for (const auto& [key, group] : cells) {
    if (static_cast<int>(group.size()) < params.min_points) continue;
    ReferenceObject o;
    if (!FitLine(group, &o)) continue;
    const Eigen::Vector2d mid = o.mid();
    const double max_rms = params.max_rms_m + params.max_rms_growth_per_m2 * mid.squaredNorm();
    if (o.length() < params.min_length_m || o.rms_m > max_rms) continue;
    if (params.radial_max_angle_rad > 0 && mid.norm() > params.radial_min_range_m &&
        o.length() > 0) {
      const Eigen::Vector2d dir = (o.b - o.a).normalized();
      const double c = std::abs(mid.normalized().dot(dir));
      const double offset = std::abs(mid.x() * dir.y() - mid.y() * dir.x());  // origin to line
      // Along the line of sight and through the view's origin: depth noise, not a surface.
      if (c > std::cos(params.radial_max_angle_rad) && offset < params.radial_min_offset_m) {
        continue;
      }
    }
    objects.push_back(o);
  }
  return objects;
}

}  // namespace epmap::perceptual_map
