#pragma once
// The stereo-extrinsics model the calibration service keeps for a head whose eyes move.
//
// The self-calibration (paper 001, Sec. III-A) estimates T_cam0_cam1 for one frame. On a head
// with verging eyes that pose changes with every frame, so a single pose would be stale at the
// next eye movement. What stays put is how the kinematic model is wrong (biased eye encoders,
// a misplaced camera): the correction
//     C = T_prior^-1 * T_estimated          (= T_cam1prior_cam1)
// is nearly constant whatever the eyes do, and the extrinsics of any frame are then
//     T_cam0_cam1 = T_prior(joints) * C.
// (For encoder biases b_l, b_r the rotation of C is exactly the vergence bias about the pan
// axis; its translation turns with the right eye's pan, by well under a millimetre.)
// Several frames' corrections are combined by their component-wise median (rotation vector and
// translation), which discards the odd frame whose baseline direction the scene pinned badly.

#include <Eigen/Geometry>
#include <string>
#include <string_view>
#include <vector>

namespace epmap::mapping {

struct StereoCorrectionModel {
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();  // T_cam1prior_cam1
  // The combined extrinsics at the first used frame's eye configuration (for people and tools;
  // the service applies `correction` to each frame's prior).
  Eigen::Isometry3d T_cam0_cam1_reference = Eigen::Isometry3d::Identity();
  int frames_used = 0;
  int frames_failed = 0;
  double correction_rotation_deg = 0.0;             // angle of C's rotation
  double correction_translation_m = 0.0;            // |C's translation|
  double spread_deg = 0.0;                          // median angle between each frame's C_i and C
  double median_vertical_offset_px = 0.0;           // rectified with prior * C, the frames used
  double prior_median_vertical_offset_px = 0.0;     // rectified with the prior alone
  int inliers = 0;                                  // RANSAC inliers, summed over frames
  double baseline_direction_prior_sigma_deg = 0.0;  // 0: the paper's procedure (data only)

  Eigen::Isometry3d Apply(const Eigen::Isometry3d& T_cam0_cam1_prior) const {
    return T_cam0_cam1_prior * correction;
  }

  std::string ToJson() const;
  // Throws std::invalid_argument with the reason on malformed JSON or a non-rotation.
  static StereoCorrectionModel FromJson(std::string_view json);
};

// C_i = T_prior_i^-1 * T_estimated_i.
Eigen::Isometry3d CorrectionOf(const Eigen::Isometry3d& T_cam0_cam1_prior,
                               const Eigen::Isometry3d& T_cam0_cam1_estimated);

// The component-wise median of the corrections' rotation vectors (angle-axis, all small) and
// translations. Throws std::invalid_argument when `corrections` is empty.
Eigen::Isometry3d MedianCorrection(const std::vector<Eigen::Isometry3d>& corrections);

// Rotation angle between two transforms' rotations, in degrees.
double RotationDifferenceDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);

}  // namespace epmap::mapping
