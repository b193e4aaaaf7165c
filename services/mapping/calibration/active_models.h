#pragma once
// The calibration models currently in force, for every part of epmapd that produces or
// consumes geometry. The calibration service swaps them (ActivateModel, RollbackModel, a job
// with activate_on_success, the state loaded at start); readers take a shared_ptr to an
// immutable model and use it without holding any lock, so a swap never blocks the pipeline.
//
// Eye-hand (paper 001, Sec. III-B): the learned map f(X_A) = X_B from where stereo vision puts
// a point in the robot's base (URDF root) frame to where the kinematics would put it. Any 3-D
// output the service computes from stereo in the base frame (e.g. the centroid of an
// unexpected region) becomes consistent with the arm's kinematics through one call:
//
//     const Eigen::Vector3d x_kinematic = active_models.CorrectVisionPoint(x_vision_base);
//
// With no eye-hand model active it returns the point unchanged.
//
// Stereo extrinsics: a StereoCorrectionModel the pipeline applies to each frame's kinematic
// prior of T_cam0_cam1 before rectifying (services/mapping/calibration/README.md).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "perception/calibration/eye_hand_model.h"
#include "services/mapping/calibration/stereo_correction.h"

namespace epmap::mapping {

class ActiveModels {
 public:
  struct EyeHand {
    std::string id;  // "eye-hand-3"
    calibration::EyeHandModel model;
  };
  struct Stereo {
    std::string id;  // "stereo-extrinsics-2"
    StereoCorrectionModel model;
  };

  // The active models (null when none of that kind is active). Thread-safe, never blocks for
  // longer than a pointer copy.
  std::shared_ptr<const EyeHand> eye_hand() const;
  std::shared_ptr<const Stereo> stereo() const;

  // x_base: a point stereo vision measured, in the base (URDF root) frame [m]. Returns the
  // active eye-hand model's f(x_base), or x_base itself when no eye-hand model is active.
  Eigen::Vector3d CorrectVisionPoint(const Eigen::Vector3d& x_base) const;

  // Empty strings when none is active.
  std::string eye_hand_id() const;
  std::string stereo_id() const;

  // Replaces (or, with nullptr, clears) the active model of one kind.
  void SetEyeHand(std::shared_ptr<const EyeHand> model);
  void SetStereo(std::shared_ptr<const Stereo> model);

 private:
  mutable std::mutex mutex_;
  std::shared_ptr<const EyeHand> eye_hand_;
  std::shared_ptr<const Stereo> stereo_;
};

}  // namespace epmap::mapping
