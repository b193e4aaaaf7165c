#pragma once
// The mixture of SE(3) experts of paper 001, Sec. III-B.3 (Eq. 10): the workspace (the X_A
// samples) is split into K clusters by k-means, an Eq. 9 expert is fitted in each cluster, and a
// point is mapped by the experts' outputs weighted with normalised Mahalanobis radial basis
// functions of the clusters' centroids c_i and covariances S_i. K is given, or chosen by
// cross-validation over paths (the K in 1..max_experts with the lowest validation error).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "perception/calibration/calibration_error.h"
#include "perception/calibration/eye_hand_model.h"
#include "perception/calibration/se3_fit.h"

namespace epmap::calibration {

struct KMeansResult {
  std::vector<int> assignment;  // cluster of each point
  Eigen::Matrix3Xd centres;
  double inertia = 0.0;  // sum of squared distances to the assigned centre
};

// Lloyd's k-means with k-means++ seeding, `restarts` seedings kept by lowest inertia. The
// result depends only on the points and the seed (own uniform draws from std::mt19937_64, so
// it is the same with every standard library). Throws CalibrationError(kInvalidInput) when
// k < 1 or k > number of points.
KMeansResult KMeans(const Eigen::Matrix3Xd& points, int k, uint64_t seed, int restarts = 5,
                    int max_iterations = 100);

struct MixtureParams {
  int experts = 4;      // K (the paper's choice); 0 = choose by cross-validation
  int max_experts = 8;  // cross-validation tries 1..max_experts
  int folds = 5;        // cross-validation folds over paths (fewer if there are fewer paths)
  uint64_t seed = 1;
  int kmeans_restarts = 5;
  int kmeans_max_iterations = 100;
  // Each cluster must hold at least this many samples (and not be collinear) to get an expert.
  int min_samples_per_expert = 12;
  // S_i = cov(cluster) + floor^2 I: keeps S_i invertible for thin clusters (a cluster on one
  // ellipse arc) and the blend smooth across them.
  double covariance_floor_m = 0.005;
  Se3FitParams expert_fit;
};

struct CrossValidationScore {
  int experts = 0;
  bool feasible = false;
  std::string reason;  // why not feasible
  double validation_mean_m = 0.0;
  double validation_rmse_m = 0.0;
};

struct MixtureFitResult {
  EyeHandModel model;
  std::vector<int> assignment;  // cluster of each sample
  std::vector<uint8_t> inlier;  // kept by its expert's outlier rejection
  std::vector<Se3FitStats> expert_stats;
  size_t outliers_rejected = 0;
  std::vector<CrossValidationScore> cross_validation;  // empty when K was given
};

// Throws CalibrationError: kInvalidInput (NaN), kDegenerate (K too large for the data: a cluster
// with too few or collinear samples; cross-validation with fewer than 2 paths), kCancelled.
MixtureFitResult FitMixture(const std::vector<EyeHandSample>& samples,
                            const MixtureParams& params = {},
                            const ProgressCallback& progress = {});

// A callback that forwards to `progress` with the fraction mapped into [begin, end].
ProgressCallback ProgressSubrange(const ProgressCallback& progress, double begin, double end);

}  // namespace epmap::calibration
