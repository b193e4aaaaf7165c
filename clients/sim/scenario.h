#pragma once
// epmap's synthetic worlds with exact ground truth (clients/sim/README.md describes each):
//   head      an iCub-like head moving its neck in a furnished room, a toy moving on its own
//   vergence  the same head with verging, tilting eyes: unrectified pairs, biased eye encoders
//   building  a differential-drive robot with a panning stereo camera driving through a floor
//   eye-hand  vision/kinematics end-effector pairs along ellipsoidal paths (no images)
//
//   auto scenario = epmap::sim::MakeScenario({.name = "head", .frames = 10});
//   epmap::sim::SimFrame f = scenario->Render(3);   // any index, any order, any thread
//
// Render(i) is a pure function of (options, i): the same seed gives the same bytes.

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/dataset/dataset.h"

namespace epmap::sim {

// 2020-09-13T12:26:40Z: the first stamp of recorded datasets, fixed so that reruns are
// byte-identical (publish uses the wall clock instead).
inline constexpr int64_t kRecordStartStampNs = 1'600'000'000'000'000'000;

struct ScenarioOptions {
  std::string name = "head";  // head | vergence | building | eye-hand
  int frames = 0;             // 0 = the scenario's default
  uint64_t seed = 1;
  int width = 0, height = 0;       // 0 = the scenario's default image size
  double encoder_noise_scale = 1;  // multiplies encoder (and odometry) noise
  double flicker_scale = 1;        // multiplies the illumination flicker
  bool noise = true;               // false: exact encoders and odometry, true chain = URDF,
                                   // no image noise, no flicker (for exactness checks)
  bool reverse = false;            // building: drive the route backwards
  // building: drive the route this many times, turning back at each end (2 = there and back):
  // a long run for what grows with time (the maps, their cost, the odometry's drift).
  int passes = 1;
  // building: both wheels travel this much more than the encoders count (UMBmark's scale
  // error E_s, e.g. 0.01 for a 1 % worn or under-inflated tyre); 0 = none, as before.
  double odometry_scale_error = 0;
  std::string route = "corridors";     // building: corridors | rooms (see BuildingRoute)
  bool disparity_every_frame = false;  // building: true disparity for every frame, not only at
                                       // the look-around stops (to score the EP map driving)
  bool walker = false;  // building: a person walks to and fro along the first corridor
  int first_frame = 0;  // building: the run starts at this frame of the whole route
  int supersample = 0;  // odd k: k x k light samples per pixel (StereoShot); 0 = the scenario's
  int64_t start_stamp_ns = kRecordStartStampNs;  // stamp of frame 0
};

// One eye-hand pair (paper 001, Sec. III-B): X_A where stereo vision saw the end effector,
// X_B where the kinematics puts it, both in the ROOT frame (the head's base_link).
struct EyeHandSample {
  int64_t stamp_ns = 0;
  Eigen::Vector3d xa = Eigen::Vector3d::Zero();
  Eigen::Vector3d xb = Eigen::Vector3d::Zero();
  std::string path;                                         // ellipsoid label, e00..e19
  Eigen::Vector3d xa_noise_free = Eigen::Vector3d::Zero();  // ground truth: X_A without noise
};

struct SimFrame {
  int index = 0;
  int64_t stamp_ns = 0;
  cv::Mat left, right;            // CV_8UC3 BGR (head, vergence) or CV_8UC1 (building)
  std::vector<double> joints;     // encoder readings, in joint_names() order
  std::vector<double> gt_joints;  // the true joint angles the frame was rendered with
  std::optional<dataset::PlanarPose> odometry;  // dead-reckoned base pose (building)

  cv::Mat gt_disparity;    // CV_32FC1 true disparity of the left image, NaN = unknown;
                           // only for rectified scenarios (head, building)
  cv::Mat gt_depth;        // CV_32FC1 z of each left pixel in cam0's frame (m), NaN = unknown
  cv::Mat gt_depth_right;  // CV_32FC1 the same for the right image in cam1's frame
  cv::Mat gt_unexpected;   // CV_8UC1 255 where something moves on its own (left image)
  // Where each thing that moves on its own is (world frame, its centre), seen or not.
  std::vector<Eigen::Vector3d> gt_mover_centres;
  Eigen::Isometry3d gt_T_world_cam0 = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d gt_T_world_cam1 = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d gt_T_cam0_cam1 = Eigen::Isometry3d::Identity();  // true stereo extrinsics
  std::optional<dataset::PlanarPose> gt_base;  // true base pose in the world (building)
  bool at_stop = false;  // building: the base stands still and the camera pans (look-around)
};

class Scenario {
 public:
  virtual ~Scenario() = default;

  const ScenarioOptions& options() const { return options_; }
  // Number of stereo frames; 0 for a scenario without images (eye-hand).
  virtual int frame_count() const = 0;
  virtual double rate_hz() const = 0;
  int64_t StampNs(int index) const;

  // Images already rectified (cam1 = cam0 shifted along x, same intrinsics, no distortion).
  virtual bool rectified() const = 0;
  // Intrinsics and the nominal T_BS (camera pose on base_link with every joint at zero).
  virtual dataset::CameraSensor cam0() const = 0;
  virtual dataset::CameraSensor cam1() const = 0;
  // The shipped URDF (kinematics.urdf) and the true chain the frames are rendered with (the
  // shipped one plus small unmodelled offsets; equal to it when options().noise is false).
  virtual std::string urdf() const = 0;
  virtual std::string true_urdf() const = 0;
  virtual std::vector<std::string> joint_names() const = 0;
  // Whether frames carry wheel odometry (SimFrame::odometry).
  virtual bool has_odometry() const { return false; }
  // Whether frames can show things that move on their own (gt_unexpected0 is recorded).
  virtual bool has_moving_objects() const { return false; }
  // A disparity range (multiple of 16) that covers the scene, for SGBM; 0 if not rectified.
  virtual int num_disparities() const { return 0; }

  // Renders frame `index` in [0, frame_count()). Thread-safe and deterministic. Throws
  // std::out_of_range for a bad index, std::logic_error for a scenario without images.
  SimFrame Render(int index) const { return RenderFrame(index, true); }
  // The same frame with only what the robot's sensors give (images, encoders, odometry, stamp)
  // and the true poses: no depth, disparity or motion masks (cheaper, for publishing).
  SimFrame RenderSensors(int index) const { return RenderFrame(index, false); }

  virtual std::vector<EyeHandSample> EyeHandSamples() const { return {}; }
  // Mobile-robot worlds: footprints (world frame) of the walls' vertical faces, door frames
  // included, and of the furniture standing on the floor.
  virtual std::vector<dataset::WallSegment> Walls() const { return {}; }
  virtual std::vector<dataset::WallSegment> Furniture() const { return {}; }
  // Whether Record writes gt_disparity0 for this frame (building: only at the look-around
  // stops, to keep the dataset small; SimFrame::gt_disparity is always filled in memory).
  virtual bool RecordsDisparity(const SimFrame& frame) const { return !frame.gt_disparity.empty(); }
  // A one-line summary for logs.
  virtual std::string Describe() const;

 protected:
  explicit Scenario(ScenarioOptions options) : options_(std::move(options)) {}
  virtual SimFrame RenderFrame(int index, bool ground_truth) const = 0;
  void CheckIndex(int index) const;

 private:
  ScenarioOptions options_;
};

std::vector<std::string> ScenarioNames();

// Throws std::invalid_argument with the reason on an unknown name, a size that is not
// positive (or given for eye-hand), a negative frame count or noise scale, or a building-only
// option (--reverse, --walker, ...) for another scenario.
std::unique_ptr<Scenario> MakeScenario(const ScenarioOptions& options);

// Parses "WxH" (e.g. "320x240"); throws std::invalid_argument unless both are positive.
std::pair<int, int> ParseImageSize(const std::string& text);

}  // namespace epmap::sim
