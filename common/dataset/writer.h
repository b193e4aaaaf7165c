#pragma once
// Writes a sequence in the dataset layout (../shared/docs/dataset-layout.md), as
// `epmap-sim record` does. Output is deterministic: the same calls give the same bytes.

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "common/dataset/dataset.h"

namespace epmap::dataset {

class Writer {
 public:
  // Creates ROOT/mav0. Throws if ROOT exists and is not empty, unless overwrite is set (then
  // ROOT's previous content is removed first).
  Writer(const std::filesystem::path& root, bool overwrite);
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  void WriteCameraSensor(int index, const CameraSensor& cam, const std::string& comment);
  void AddStereoFrame(int64_t stamp_ns, const cv::Mat& left, const cv::Mat& right);
  void SetJointNames(const std::vector<std::string>& names);
  void AddJoints(int64_t stamp_ns, const std::vector<double>& positions);
  void AddOdometry(const PlanarPose& pose);
  void WriteUrdf(const std::string& urdf_xml);
  void AddGtCameraPose(int64_t stamp_ns, const Eigen::Isometry3d& T_world_cam0);
  void AddGtBasePose(const PlanarPose& pose);
  void AddGtDisparity(int64_t stamp_ns, const cv::Mat& disparity);  // CV_32FC1, NaN unknown
  void AddGtUnexpected(int64_t stamp_ns, const cv::Mat& mask);      // CV_8UC1
  void WriteWalls(const std::vector<WallSegment>& walls);
  // Writes any extra file under mav0/ (e.g. eye-hand samples.csv); returns its path.
  std::filesystem::path WriteFile(const std::string& relative, const std::string& content);

  const std::filesystem::path& mav0() const { return mav0_; }

 private:
  std::FILE* Csv(const std::string& folder, const std::string& header);

  std::filesystem::path root_;
  std::filesystem::path mav0_;
  struct OpenCsv;
  std::vector<std::unique_ptr<OpenCsv>> csvs_;
  std::vector<std::string> joint_names_;
};

}  // namespace epmap::dataset
