#include "perception/calibration/two_view_geometry.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace epmap::calibration {

namespace {

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

double Uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

// k distinct indices in [0, n).
void SampleDistinct(std::mt19937_64& rng, size_t n, size_t k, std::vector<size_t>& out) {
  out.clear();
  while (out.size() < k) {
    const auto i = static_cast<size_t>(Uniform01(rng) * static_cast<double>(n));
    if (std::find(out.begin(), out.end(), i) == out.end()) out.push_back(i);
  }
}

// Hartley normalisation: centroid to the origin, mean distance sqrt(2).
Eigen::Matrix3d NormalisingTransform(const std::vector<Eigen::Vector2d>& p,
                                     const std::vector<size_t>* subset) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  const size_t n = subset ? subset->size() : p.size();
  const auto at = [&](size_t i) -> const Eigen::Vector2d& {
    return subset ? p[(*subset)[i]] : p[i];
  };
  for (size_t i = 0; i < n; ++i) mean += at(i);
  mean /= static_cast<double>(n);
  double dist = 0;
  for (size_t i = 0; i < n; ++i) dist += (at(i) - mean).norm();
  dist /= static_cast<double>(n);
  const double s = dist > 0 ? std::sqrt(2.0) / dist : 1.0;
  Eigen::Matrix3d t;
  t << s, 0, -s * mean.x(), 0, s, -s * mean.y(), 0, 0, 1;
  return t;
}

Eigen::Matrix3d EightPoint(const std::vector<Eigen::Vector2d>& left,
                           const std::vector<Eigen::Vector2d>& right,
                           const std::vector<size_t>* subset) {
  const size_t n = subset ? subset->size() : left.size();
  const Eigen::Matrix3d tl = NormalisingTransform(left, subset);
  const Eigen::Matrix3d tr = NormalisingTransform(right, subset);
  Eigen::Matrix<double, 9, 9> ata = Eigen::Matrix<double, 9, 9>::Zero();
  for (size_t k = 0; k < n; ++k) {
    const size_t i = subset ? (*subset)[k] : k;
    const Eigen::Vector3d l = tl * left[i].homogeneous();
    const Eigen::Vector3d r = tr * right[i].homogeneous();
    Eigen::Matrix<double, 9, 1> row;
    // x_r^T F x_l = sum_ij r_i F_ij l_j, F row-major.
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) row(3 * a + b) = r(a) * l(b);
    }
    ata.noalias() += row * row.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(ata);
  const Eigen::Matrix<double, 9, 1> v = eig.eigenvectors().col(0);  // smallest eigenvalue
  Eigen::Matrix3d f;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) f(a, b) = v(3 * a + b);
  }
  // Rank 2: zero the smallest singular value.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d sv = svd.singularValues();
  sv(2) = 0;
  f = svd.matrixU() * sv.asDiagonal() * svd.matrixV().transpose();
  f = tr.transpose() * f * tl;
  return f / f.norm();
}

Eigen::Matrix3d FourPointHomography(const std::vector<Eigen::Vector2d>& left,
                                    const std::vector<Eigen::Vector2d>& right,
                                    const std::vector<size_t>& subset) {
  const Eigen::Matrix3d tl = NormalisingTransform(left, &subset);
  const Eigen::Matrix3d tr = NormalisingTransform(right, &subset);
  Eigen::Matrix<double, 9, 9> ata = Eigen::Matrix<double, 9, 9>::Zero();
  for (size_t i : subset) {
    const Eigen::Vector3d l = tl * left[i].homogeneous();
    const Eigen::Vector3d r = tr * right[i].homogeneous();
    // r x (H l) = 0: two independent rows.
    Eigen::Matrix<double, 9, 1> a1, a2;
    a1 << 0, 0, 0, -r.z() * l, r.y() * l;
    a2 << r.z() * l, 0, 0, 0, -r.x() * l;
    ata.noalias() += a1 * a1.transpose() + a2 * a2.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(ata);
  const Eigen::Matrix<double, 9, 1> v = eig.eigenvectors().col(0);
  Eigen::Matrix3d h;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) h(a, b) = v(3 * a + b);
  }
  return tr.inverse() * h * tl;
}

double SampsonSquared(const Eigen::Matrix3d& f, const Eigen::Vector2d& left,
                      const Eigen::Vector2d& right) {
  const Eigen::Vector3d l = left.homogeneous();
  const Eigen::Vector3d r = right.homogeneous();
  const Eigen::Vector3d fl = f * l;
  const Eigen::Vector3d ftr = f.transpose() * r;
  const double num = r.dot(fl);
  const double den = fl.x() * fl.x() + fl.y() * fl.y() + ftr.x() * ftr.x() + ftr.y() * ftr.y();
  return den > 0 ? num * num / den : std::numeric_limits<double>::infinity();
}

int AdaptiveIterations(double inlier_share, int sample_size, double confidence, int cap) {
  const double w = std::pow(std::clamp(inlier_share, 1e-9, 1.0), sample_size);
  if (w >= 1.0 - 1e-12) return 1;
  const double it = std::log(1.0 - confidence) / std::log(1.0 - w);
  return static_cast<int>(std::min<double>(cap, std::ceil(it)));
}

}  // namespace

Eigen::Matrix3d FundamentalFromProjections(const Matrix34d& p_left, const Matrix34d& p_right) {
  // Eq. 4-5: X_i / Y_i are the 2x4 blocks of rows (i+1, i+2 mod 3) of P_L / P_R. Taking the
  // rows cyclically absorbs the (-1)^(i+j) sign of the cofactor form (H&Z eq. 17.3).
  const auto rows = [](const Matrix34d& p, int i) {
    Eigen::Matrix<double, 2, 4> m;
    m.row(0) = p.row((i + 1) % 3);
    m.row(1) = p.row((i + 2) % 3);
    return m;
  };
  Eigen::Matrix3d f;
  for (int i = 0; i < 3; ++i) {    // row of F: Y_i (right camera)
    for (int j = 0; j < 3; ++j) {  // column of F: X_j (left camera)
      Eigen::Matrix4d m;
      m.topRows<2>() = rows(p_left, j);
      m.bottomRows<2>() = rows(p_right, i);
      f(i, j) = m.determinant();  // Eq. 6
    }
  }
  const double n = f.norm();
  if (!(n > 0)) {
    throw CalibrationError(ErrorCode::kDegenerate,
                           "the camera matrices give F = 0: the two camera centres coincide");
  }
  return f / n;
}

Eigen::Matrix3d FundamentalFromExtrinsics(const Eigen::Matrix3d& k_left,
                                          const Eigen::Matrix3d& k_right,
                                          const Eigen::Matrix3d& r_right_left,
                                          const Eigen::Vector3d& t_right_left) {
  const Eigen::Matrix3d f =
      k_right.inverse().transpose() * Hat(t_right_left) * r_right_left * k_left.inverse();
  return f / f.norm();
}

Eigen::Matrix3d EssentialFromFundamental(const Eigen::Matrix3d& f, const Eigen::Matrix3d& k_left,
                                         const Eigen::Matrix3d& k_right) {
  return k_right.transpose() * f * k_left;  // Eq. 7
}

double SampsonDistance(const Eigen::Matrix3d& f, const Eigen::Vector2d& left,
                       const Eigen::Vector2d& right) {
  return std::sqrt(SampsonSquared(f, left, right));
}

Eigen::Matrix3d EightPointFundamental(const std::vector<Eigen::Vector2d>& left,
                                      const std::vector<Eigen::Vector2d>& right) {
  if (left.size() != right.size() || left.size() < 8) {
    throw CalibrationError(ErrorCode::kDegenerate,
                           "the 8-point algorithm needs at least 8 matches, got " +
                               std::to_string(std::min(left.size(), right.size())));
  }
  return EightPoint(left, right, nullptr);
}

RansacResult RansacFundamental(const std::vector<Eigen::Vector2d>& left,
                               const std::vector<Eigen::Vector2d>& right,
                               const RansacParams& params, const ProgressCallback& progress) {
  const size_t n = left.size();
  if (n != right.size() || n < 8) {
    throw CalibrationError(ErrorCode::kDegenerate, "RANSAC for F needs at least 8 matches, got " +
                                                       std::to_string(std::min(n, right.size())));
  }
  const double thr2 = params.threshold_px * params.threshold_px;
  std::mt19937_64 rng(params.seed);
  std::vector<size_t> sample;
  RansacResult best;
  double best_cost = std::numeric_limits<double>::infinity();
  int needed = params.max_iterations;
  int it = 0;
  const auto score = [&](const Eigen::Matrix3d& f, std::vector<uint8_t>* mask) {
    double cost = 0;
    int count = 0;
    for (size_t i = 0; i < n; ++i) {
      const double d2 = SampsonSquared(f, left[i], right[i]);
      const bool in = d2 < thr2;
      cost += in ? d2 : thr2;  // MSAC: truncated quadratic
      count += in ? 1 : 0;
      if (mask) (*mask)[i] = in ? 1 : 0;
    }
    return std::pair<double, int>(cost, count);
  };
  for (; it < std::max(needed, params.min_iterations) && it < params.max_iterations; ++it) {
    if (progress && it % 64 == 0) {
      ReportProgress(progress, {"ransac", static_cast<uint64_t>(it), best_cost / n,
                                std::min(1.0, static_cast<double>(it) / std::max(1, needed))});
    }
    SampleDistinct(rng, n, 8, sample);
    const Eigen::Matrix3d f = EightPoint(left, right, &sample);
    if (!f.allFinite()) continue;
    const auto [cost, count] = score(f, nullptr);
    if (cost < best_cost) {
      best_cost = cost;
      best.f = f;
      best.inliers = count;
      needed = AdaptiveIterations(static_cast<double>(count) / static_cast<double>(n), 8,
                                  params.confidence, params.max_iterations);
    }
  }
  best.iterations = it;
  best.inlier.assign(n, 0);
  score(best.f, &best.inlier);
  // Local optimisation: least-squares 8-point on all inliers while that lowers the MSAC cost.
  for (int r = 0; r < params.local_refits; ++r) {
    std::vector<size_t> in;
    for (size_t i = 0; i < n; ++i) {
      if (best.inlier[i]) in.push_back(i);
    }
    if (in.size() < 8) break;
    const Eigen::Matrix3d f = EightPoint(left, right, &in);
    std::vector<uint8_t> mask(n);
    const auto [cost, count] = score(f, &mask);
    if (!(cost < best_cost)) break;
    best_cost = cost;
    best.f = f;
    best.inliers = count;
    best.inlier = std::move(mask);
  }
  return best;
}

RansacResult RansacHomography(const std::vector<Eigen::Vector2d>& left,
                              const std::vector<Eigen::Vector2d>& right, double threshold_px,
                              int iterations, uint64_t seed) {
  const size_t n = left.size();
  RansacResult best;
  best.inlier.assign(n, 0);
  if (n < 4 || n != right.size()) return best;
  std::mt19937_64 rng(seed);
  std::vector<size_t> sample;
  const double thr2 = threshold_px * threshold_px;
  Eigen::Matrix3d best_h = Eigen::Matrix3d::Identity();
  for (int it = 0; it < iterations; ++it) {
    SampleDistinct(rng, n, 4, sample);
    const Eigen::Matrix3d h = FourPointHomography(left, right, sample);
    if (!h.allFinite()) continue;
    int count = 0;
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d p = h * left[i].homogeneous();
      if (std::abs(p.z()) > 1e-12 && (p.hnormalized() - right[i]).squaredNorm() < thr2) ++count;
    }
    if (count > best.inliers) {
      best.inliers = count;
      best_h = h;
    }
    best.iterations = it + 1;
  }
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = best_h * left[i].homogeneous();
    best.inlier[i] =
        std::abs(p.z()) > 1e-12 && (p.hnormalized() - right[i]).squaredNorm() < thr2 ? 1 : 0;
  }
  best.f = best_h;
  return best;
}

Eigen::Vector3d Triangulate(const Eigen::Matrix3d& r, const Eigen::Vector3d& t,
                            const Eigen::Vector2d& l, const Eigen::Vector2d& x) {
  Matrix34d p1 = Matrix34d::Zero();
  p1.leftCols<3>().setIdentity();
  Matrix34d p2;
  p2.leftCols<3>() = r;
  p2.col(3) = t;
  Eigen::Matrix4d a;
  a.row(0) = l.x() * p1.row(2) - p1.row(0);
  a.row(1) = l.y() * p1.row(2) - p1.row(1);
  a.row(2) = x.x() * p2.row(2) - p2.row(0);
  a.row(3) = x.y() * p2.row(2) - p2.row(1);
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(a, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  return h.head<3>() / h(3);
}

std::array<RelativePose, 4> DecomposeEssential(const Eigen::Matrix3d& e,
                                               const std::vector<Eigen::Vector2d>& left,
                                               const std::vector<Eigen::Vector2d>& right) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(e, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  Eigen::Matrix3d v = svd.matrixV();
  if (u.determinant() < 0) u = -u;
  if (v.determinant() < 0) v = -v;
  Eigen::Matrix3d w;
  w << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Eigen::Matrix3d r1 = u * w * v.transpose();
  const Eigen::Matrix3d r2 = u * w.transpose() * v.transpose();
  const Eigen::Vector3d t = u.col(2);
  std::array<RelativePose, 4> out{{{r1, t, 0}, {r1, -t, 0}, {r2, t, 0}, {r2, -t, 0}}};
  for (auto& c : out) {
    for (size_t i = 0; i < left.size(); ++i) {
      const Eigen::Vector3d x = Triangulate(c.r, c.t, left[i], right[i]);
      // In front of both cameras: positive depth in the left frame and in the right frame.
      if (x.allFinite() && x.z() > 0 && (c.r * x + c.t).z() > 0) ++c.in_front;
    }
  }
  return out;
}

RelativePose ChooseByChirality(const std::array<RelativePose, 4>& candidates) {
  return *std::max_element(candidates.begin(), candidates.end(),
                           [](const auto& a, const auto& b) { return a.in_front < b.in_front; });
}

}  // namespace epmap::calibration
