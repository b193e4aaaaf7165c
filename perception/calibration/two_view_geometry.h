#pragma once
// Two-view geometry for the stereo self-calibration of paper 001, Sec. III-A: the kinematic-
// prior fundamental matrix from two camera matrices (Eq. 4-6), the normalised 8-point algorithm
// inside a RANSAC loop, the essential matrix (Eq. 7) and its four decompositions told apart by
// chirality. Pixel coordinates are of undistorted images; "left" is cam0, "right" is cam1, and
// a match satisfies x_right^T F x_left = 0.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "perception/calibration/calibration_error.h"

namespace epmap::calibration {

using Matrix34d = Eigen::Matrix<double, 3, 4>;

// Eq. 4-6: F_K(i, j) = det([X_j; Y_i]) where X_i is P_left without row i (rows i+1, i+2 mod 3)
// and Y_i the same rows of P_right. Returned with unit Frobenius norm.
Eigen::Matrix3d FundamentalFromProjections(const Matrix34d& p_left, const Matrix34d& p_right);

// F = K_R^-T [t]x R K_L^-1 for x_right = R x_left + t (cam1 <- cam0), unit Frobenius norm.
Eigen::Matrix3d FundamentalFromExtrinsics(const Eigen::Matrix3d& k_left,
                                          const Eigen::Matrix3d& k_right,
                                          const Eigen::Matrix3d& r_right_left,
                                          const Eigen::Vector3d& t_right_left);

// Eq. 7: E = K_R^T F K_L.
Eigen::Matrix3d EssentialFromFundamental(const Eigen::Matrix3d& f, const Eigen::Matrix3d& k_left,
                                         const Eigen::Matrix3d& k_right);

// First-order geometric (Sampson) distance of a match to F, in pixels: sqrt of
// (x_r^T F x_l)^2 / ((F x_l)_1^2 + (F x_l)_2^2 + (F^T x_r)_1^2 + (F^T x_r)_2^2).
double SampsonDistance(const Eigen::Matrix3d& f, const Eigen::Vector2d& left,
                       const Eigen::Vector2d& right);

// Hartley's normalised 8-point algorithm on >= 8 matches (all of them, least squares), rank 2
// enforced, unit Frobenius norm. Throws CalibrationError(kDegenerate) on fewer than 8.
Eigen::Matrix3d EightPointFundamental(const std::vector<Eigen::Vector2d>& left,
                                      const std::vector<Eigen::Vector2d>& right);

struct RansacParams {
  double threshold_px = 1.0;  // Sampson distance of an inlier
  double confidence = 0.999;
  int max_iterations = 5000;
  int min_iterations = 100;
  int local_refits = 5;  // 8-point refits on the inliers after the loop
  uint64_t seed = 7;
};

struct RansacResult {
  Eigen::Matrix3d f = Eigen::Matrix3d::Zero();
  std::vector<uint8_t> inlier;
  int inliers = 0;
  int iterations = 0;
};

// RANSAC (MSAC scoring, adaptive iteration count) over minimal samples of 8 solved with the
// normalised 8-point algorithm, then refitted on all inliers. Throws kDegenerate on < 8 matches,
// kCancelled if the callback asks.
RansacResult RansacFundamental(const std::vector<Eigen::Vector2d>& left,
                               const std::vector<Eigen::Vector2d>& right,
                               const RansacParams& params = {},
                               const ProgressCallback& progress = {});

// RANSAC homography (4-point, transfer distance in the right image): used to detect scenes
// whose matches a homography explains (a plane, or no parallax), where F is undetermined.
RansacResult RansacHomography(const std::vector<Eigen::Vector2d>& left,
                              const std::vector<Eigen::Vector2d>& right, double threshold_px,
                              int iterations, uint64_t seed);

// One decomposition of E: x_right = R x_left + t, |t| = 1.
struct RelativePose {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::UnitX();
  int in_front = 0;  // matches triangulated in front of both cameras
};

// The four (R, t) of E (Hartley & Zisserman, Result 9.19), each with its chirality count over
// the given matches in normalised camera coordinates (K^-1 x).
std::array<RelativePose, 4> DecomposeEssential(
    const Eigen::Matrix3d& e, const std::vector<Eigen::Vector2d>& left_normalised,
    const std::vector<Eigen::Vector2d>& right_normalised);
// The decomposition with the most matches in front of both cameras.
RelativePose ChooseByChirality(const std::array<RelativePose, 4>& candidates);

// Linear (DLT) triangulation in the left camera's frame, for P_left = [I|0], P_right = [R|t] and
// normalised coordinates.
Eigen::Vector3d Triangulate(const Eigen::Matrix3d& r, const Eigen::Vector3d& t,
                            const Eigen::Vector2d& left_normalised,
                            const Eigen::Vector2d& right_normalised);

}  // namespace epmap::calibration
