#pragma once
// The dataset layout of ../shared/docs/dataset-layout.md: EuRoC/ASL sequences (cam0, cam1,
// optional joints0, odometry0, kinematics.urdf and ground-truth folders) and single
// rectified stereo-pair folders (left.png, right.png, pair.yaml). Reading is lazy for images:
// the loader indexes files, the caller decodes the frames it needs.

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera/camera_model.h"

namespace epmap::dataset {

// One camera as described by an EuRoC sensor.yaml.
struct CameraSensor {
  int width = 0;
  int height = 0;
  double fu = 0, fv = 0, cu = 0, cv = 0;
  std::string distortion_model = "radial-tangential";  // or "equidistant"
  std::vector<double> distortion;                      // k1 k2 p1 p2 (or k1..k4)
  Eigen::Matrix4d T_BS = Eigen::Matrix4d::Identity();  // camera pose in the body frame
  double rate_hz = 0;

  // Size and pinhole intrinsics, without the distortion.
  camera::PinholeIntrinsics pinhole() const { return {width, height, fu, fv, cu, cv}; }
};

// The description of a rectified (distortion-free) pinhole camera at T_base_cam, as the
// synthetic datasets write it.
CameraSensor RectifiedPinholeSensor(int width, int height, double fx, double fy, double cx,
                                    double cy, const Eigen::Isometry3d& T_base_cam, double rate_hz);

struct StereoFrame {
  int64_t stamp_ns = 0;
  std::filesystem::path left;
  std::filesystem::path right;
};

struct JointSample {
  int64_t stamp_ns = 0;
  std::vector<double> positions;  // in the order of Dataset::joint_names
};

struct PlanarPose {
  int64_t stamp_ns = 0;
  double x = 0, y = 0, theta = 0;
};

struct PoseSample {
  int64_t stamp_ns = 0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // T_world_cam0
};

struct WallSegment {
  double x1 = 0, y1 = 0, x2 = 0, y2 = 0;
};

// Where a thing that moves on its own is at a frame (gt_movers0: a synthetic-world extension).
struct MoverSample {
  int64_t stamp_ns = 0;
  int id = 0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // world frame (m)
};

struct Dataset {
  enum class Kind { kSequence, kStereoPair };
  Kind kind = Kind::kSequence;
  std::filesystem::path root;  // the folder holding mav0/ (or the pair folder)

  CameraSensor cam0;
  CameraSensor cam1;
  std::vector<StereoFrame> frames;  // left/right matched by timestamp, in time order

  std::vector<std::string> joint_names;
  std::vector<JointSample> joints;
  std::vector<PlanarPose> odometry;
  std::optional<std::filesystem::path> urdf;

  std::vector<PoseSample> gt_camera_pose;
  std::vector<PlanarPose> gt_base_pose;
  std::map<int64_t, std::filesystem::path> gt_disparity;
  std::map<int64_t, std::filesystem::path> gt_unexpected;
  std::vector<MoverSample> gt_movers;  // in time order
  std::vector<WallSegment> walls;

  // Stereo-pair folders: scale of the stored ground truth, and the disparity range.
  double gt_scale = 1.0;
  int min_disparity = 0;
  int num_disparities = 0;  // 0 = not stated

  bool rectified() const;     // zero distortion, same intrinsics, pure-x baseline
  double baseline_m() const;  // |t| between the two cameras
};

// Loads a dataset from DIR, DIR/mav0's parent, or a stereo-pair folder. Throws
// std::runtime_error naming the file and the problem when something required is missing or
// malformed (a missing optional folder is not an error).
Dataset Load(const std::filesystem::path& path);

// The true disparity of a frame as CV_32FC1 with NaN where unknown, or an empty Mat if the
// dataset has none for that stamp.
cv::Mat LoadGtDisparity(const Dataset& dataset, int64_t stamp_ns);
// The true unexpected-motion mask (CV_8UC1, 255 = moving) or an empty Mat.
cv::Mat LoadGtUnexpected(const Dataset& dataset, int64_t stamp_ns);

// Joint positions linearly interpolated at stamp_ns (clamped at the ends). Returns nullopt if
// there are no samples or stamp_ns is more than max_gap_ns outside their span.
std::optional<std::vector<double>> InterpolateJoints(const std::vector<JointSample>& samples,
                                                     int64_t stamp_ns,
                                                     int64_t max_gap_ns = 100'000'000);

// The pose recorded at exactly stamp_ns (samples sorted by stamp, one per frame, as
// gt_camera_pose0 is written), or nullopt.
std::optional<Eigen::Isometry3d> PoseAt(const std::vector<PoseSample>& samples, int64_t stamp_ns);

// Planar pose interpolated at stamp_ns (angle interpolated on the circle).
std::optional<PlanarPose> InterpolatePlanar(const std::vector<PlanarPose>& samples,
                                            int64_t stamp_ns, int64_t max_gap_ns = 500'000'000);

// Reads an EuRoC sensor.yaml (tolerates the OpenCV "%YAML:1.0" first line).
CameraSensor ReadCameraSensor(const std::filesystem::path& sensor_yaml);

}  // namespace epmap::dataset
