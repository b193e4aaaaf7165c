#pragma once
// Eye-hand samples (paper 001, Sec. III-B): pairs (X_A, X_B) of the end effector's position as
// stereo vision sees it (X_A) and as the kinematics puts it (X_B), both in the ROOT frame, each
// tagged with the trajectory ("path": one ellipsoid of the data acquisition) it belongs to.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace epmap::calibration {

struct EyeHandSample {
  int64_t stamp_ns = 0;
  Eigen::Vector3d xa = Eigen::Vector3d::Zero();  // vision, ROOT frame [m]
  Eigen::Vector3d xb = Eigen::Vector3d::Zero();  // kinematics, ROOT frame [m]
  std::string path;
};

// Reads the CSV written by `epmap-sim record --scenario eye-hand` and by WriteEyeHandCsv:
// header `#timestamp [ns],xa [m],ya [m],za [m],xb [m],yb [m],zb [m],path`, one sample per row.
// Throws CalibrationError(kInvalidInput) naming the file, line and problem.
std::vector<EyeHandSample> ReadEyeHandCsv(const std::filesystem::path& csv);
void WriteEyeHandCsv(const std::filesystem::path& csv, const std::vector<EyeHandSample>& samples);

// Throws CalibrationError(kInvalidInput) if any coordinate is not finite (naming the sample).
void ValidateSamples(const std::vector<EyeHandSample>& samples);

// Path labels in order of first appearance.
std::vector<std::string> PathNames(const std::vector<EyeHandSample>& samples);
// Samples whose path is (or is not) in `paths`.
std::vector<EyeHandSample> SelectPaths(const std::vector<EyeHandSample>& samples,
                                       const std::vector<std::string>& paths, bool keep = true);

// A train/test split by whole paths (the paper tests on unseen trajectories): round(share * P)
// of the P paths, at least 1 and at most P - 1, chosen by a seeded shuffle of the sorted path
// names (the same split for the same samples and seed). Throws CalibrationError(kInvalidInput)
// with fewer than 2 paths or a share outside (0, 1).
struct PathSplit {
  std::vector<EyeHandSample> train, test;
  std::vector<std::string> test_paths;
};
PathSplit SplitByPaths(const std::vector<EyeHandSample>& samples, double test_share, uint64_t seed);

// The X_A (or X_B) coordinates as a 3xN matrix.
Eigen::Matrix3Xd PointsA(const std::vector<EyeHandSample>& samples);
Eigen::Matrix3Xd PointsB(const std::vector<EyeHandSample>& samples);

// The shape of a point cloud: principal standard deviations, largest first. A cloud is a line
// when sigma[1] is tiny next to sigma[0], a plane when sigma[2] is (see Se3FitParams).
struct PointSpread {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma = Eigen::Vector3d::Zero();     // descending
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // column i = direction of sigma[i]
};
PointSpread MeasureSpread(const Eigen::Matrix3Xd& points);

}  // namespace epmap::calibration
