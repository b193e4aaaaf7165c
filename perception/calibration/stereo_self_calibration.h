#pragma once
// Online stereo extrinsic self-calibration, paper 001, Sec. III-A: SIFT on undistorted images,
// ratio-test matching, a kinematic-prior fundamental matrix F_K (Eq. 4-6) that gates the matches,
// RANSAC with the normalised 8-point algorithm for F, E = K_R^T F K_L (Eq. 7), the decomposition
// in front of both cameras (chirality), acceptance only near the kinematic prior, translation
// scaled to the known baseline, and Bouguet rectification built from the result.
//
// Units of the gate: the paper discards matches with |x'^T F_K x| > 0.01 without saying how F_K
// and x are scaled, so that number cannot be carried over. We gate with the Sampson distance to
// F_K in pixels, a quantity with a meaning: the gate is derived from the tolerance we accept the
// result within (a rotation error of delta moves epipolar lines by up to f tan(delta) pixels),
// gate = f tan(max_rotation_deviation) + 2 * ransac threshold, unless set explicitly. (If the
// paper's x were normalised camera coordinates, 0.01 would be ~0.6 degrees of epipolar error.)

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "perception/calibration/calibration_error.h"
#include "perception/calibration/two_view_geometry.h"
#include "perception/kinematics/urdf_chain.h"
#include "perception/stereo/rectification.h"

namespace epmap::calibration {

// One camera's intrinsics (EuRoC sensor.yaml terms).
struct CameraIntrinsics {
  int width = 0;
  int height = 0;
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();
  std::vector<double> distortion;                      // k1 k2 p1 p2 [k3] or k1..k4
  std::string distortion_model = "radial-tangential";  // or "equidistant"
};

// One stereo frame: raw (distorted) images and the kinematic prior of the extrinsics, i.e.
// T_cam0_cam1 (maps cam1 points into cam0) computed from the eye encoders through the URDF.
struct StereoView {
  cv::Mat left;   // cam0
  cv::Mat right;  // cam1
  Eigen::Isometry3d T_cam0_cam1_prior = Eigen::Isometry3d::Identity();
  int64_t stamp_ns = 0;
};

struct StereoSelfCalibrationParams {
  int max_features = 4000;     // SIFT keypoints per image (strongest kept)
  double ratio_test = 0.8;     // Lowe's ratio (the paper does not state one)
  bool mutual_best = true;     // keep a match only if it is best in both directions
  double prior_gate_px = 0.0;  // Sampson distance to F_K; 0 = derived (see header)
  RansacParams ransac;         // normalised 8-point RANSAC (Sampson, px)
  bool refine = true;          // minimise the Sampson error over R, t after RANSAC
  // Optional (not in the paper): a Gaussian prior on the baseline direction (cam1's centre seen
  // from cam0) in the refinement, sigma in degrees; 0 = off, the data alone decide. With little
  // parallax (a far scene) the direction is weakly determined by the images while the eyes'
  // centres are well known from the head's geometry; the prior then keeps t near the kinematic
  // value and lets strong parallax override it. feature_noise_px weighs it against the data.
  double baseline_direction_prior_sigma_deg = 0.0;
  double feature_noise_px = 0.5;
  int min_keypoints = 40;  // per image, over all views
  int min_matches = 30;    // prior-consistent matches
  int min_inliers = 20;    // RANSAC inliers
  // Planar / no-parallax scenes: F is undetermined when a homography explains the matches.
  double homography_threshold_px = 2.0;
  double planar_inlier_ratio = 0.85;  // H inliers / F inliers at or above this = refused
  // Acceptance against the kinematic prior (the paper: "given a certain tolerance").
  double max_rotation_deviation_deg = 3.0;
  double max_baseline_direction_deviation_deg = 3.0;
  // Multi-frame: all views must share one eye configuration within this (degrees).
  double max_view_prior_spread_deg = 0.05;
  double baseline_m = 0.0;  // |t| of the result; 0 = the prior's baseline length
};

// The recovered extrinsics, as stored by the calibration service.
struct StereoExtrinsicsModel {
  Eigen::Isometry3d T_cam0_cam1 = Eigen::Isometry3d::Identity();
  double rotation_deviation_deg = 0.0;            // from the kinematic prior
  double baseline_direction_deviation_deg = 0.0;  // from the kinematic prior
  int inliers = 0;
  double rms_sampson_px = 0.0;

  std::string ToJson() const;
  // Throws CalibrationError(kInvalidInput) on malformed JSON or a non-rotation.
  static StereoExtrinsicsModel FromJson(std::string_view json);
};

struct StereoSelfCalibrationResult {
  StereoExtrinsicsModel model;
  Eigen::Matrix3d f = Eigen::Matrix3d::Zero();        // x_right^T F x_left = 0, undistorted px
  Eigen::Matrix3d e = Eigen::Matrix3d::Zero();        // Eq. 7
  Eigen::Matrix3d f_prior = Eigen::Matrix3d::Zero();  // F_K of the first view (Eq. 4-6)
  int keypoints_left = 0, keypoints_right = 0;        // summed over views
  int putative_matches = 0;                           // after the ratio test
  int prior_consistent_matches = 0;                   // after the F_K gate
  int homography_inliers = 0;
  int ransac_iterations = 0;
  double prior_gate_px = 0.0;
  std::vector<Eigen::Vector2d> inlier_left, inlier_right;  // undistorted px
};

// Single- or multi-frame self-calibration (views accumulate their prior-consistent matches
// before RANSAC; they must share one eye configuration). Throws CalibrationError:
// kInvalidInput (empty/mismatched images, views with different priors), kInsufficientFeatures,
// kPlanarScene, kRejectedByPrior, kNotConverged, kCancelled.
StereoSelfCalibrationResult SelfCalibrateStereo(const CameraIntrinsics& cam0,
                                                const CameraIntrinsics& cam1,
                                                const std::vector<StereoView>& views,
                                                const StereoSelfCalibrationParams& params = {},
                                                const ProgressCallback& progress = {});

// The kinematic prior of the extrinsics for encoder readings `joints` (in the chain's bound
// order): T_cam0_cam1 = T_root_cam0^-1 T_root_cam1 through the URDF. Throws
// CalibrationError(kInvalidInput) if the URDF has no cam1_optical or the joints are invalid.
Eigen::Isometry3d KinematicPrior(const kinematics::UrdfChain& chain,
                                 const std::vector<double>& joints);

// The camera matrices of the prior: P_L = K_L [I | 0], P_R = K_R [R | t], (R, t) = T_cam1_cam0.
Matrix34d LeftCameraMatrix(const CameraIntrinsics& cam0);
Matrix34d RightCameraMatrix(const CameraIntrinsics& cam1, const Eigen::Isometry3d& T_cam0_cam1);

// Bouguet rectification (cv::stereoRectify + initUndistortRectifyMap, through
// perception/stereo) for the given extrinsics. Fills the ROS-style camera parameters if asked.
stereo::Rectifier MakeRectifier(const CameraIntrinsics& cam0, const CameraIntrinsics& cam1,
                                const Eigen::Isometry3d& T_cam0_cam1,
                                stereo::CameraParameters* left = nullptr,
                                stereo::CameraParameters* right = nullptr);

// Angle of R_a^T R_b and angle between two directions, in degrees.
double RotationAngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);
double DirectionAngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

// SIFT keypoints of both images matched with the ratio test (and mutual best), pixel
// coordinates of the images as given. Used by the self-calibration and by evaluations.
void MatchSift(const cv::Mat& left, const cv::Mat& right, int max_features, double ratio_test,
               bool mutual_best, std::vector<Eigen::Vector2d>* left_points,
               std::vector<Eigen::Vector2d>* right_points, int* keypoints_left = nullptr,
               int* keypoints_right = nullptr);

// How well a pair is rectified, judged by the images alone: the median |row difference| of SIFT
// matches between the rectified images (px; 0 = perfect), matches 20 px or more apart dropped as
// gross mismatches (no plausible calibration puts one point that far off its row); NaN without
// a match. What the stereo job reports, and the check of a calibration in tests and benchmarks.
double MedianRowOffset(const cv::Mat& rectified_left, const cv::Mat& rectified_right);
// The same for raw images rectified with the given calibration (MakeRectifier).
double MedianRowOffset(const CameraIntrinsics& cam0, const CameraIntrinsics& cam1,
                       const Eigen::Isometry3d& T_cam0_cam1, const cv::Mat& left,
                       const cv::Mat& right);

}  // namespace epmap::calibration
