#include "perception/localisation/pose_corrector.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace epmap::localisation {

const char* ToString(HeadingSource s) {
  switch (s) {
    case HeadingSource::kStart:
      return "start";
    case HeadingSource::kStationary:
      return "stationary";
    case HeadingSource::kVisual:
      return "visual";
    case HeadingSource::kOdometry:
      return "odometry";
  }
  return "?";
}

double HeadingOf(const Eigen::Isometry2d& T) {
  return std::atan2(T.linear()(1, 0), T.linear()(0, 0));
}

double WrapAngle(double a) {
  a = std::remainder(a, 2.0 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2.0 * std::numbers::pi : a;
}

Eigen::Isometry2d MakePose(double x, double y, double theta) {
  Eigen::Isometry2d T = Eigen::Isometry2d::Identity();
  T.linear() = Eigen::Rotation2Dd(theta).toRotationMatrix();
  T.translation() = Eigen::Vector2d(x, y);
  return T;
}

void PoseCorrectorParams::Validate() const {
  if (!(stationary_translation_m >= 0) || !(stationary_rotation_rad >= 0)) {
    throw std::invalid_argument("pose corrector: stationary thresholds must be >= 0");
  }
  if (!(max_disagreement_rad > 0)) {
    throw std::invalid_argument("pose corrector: max_disagreement_rad must be > 0");
  }
}

PoseCorrector::PoseCorrector(const PoseCorrectorParams& params) : params_(params) {
  params_.Validate();
}

bool PoseCorrector::Moved(const Eigen::Isometry2d& a, const Eigen::Isometry2d& b) const {
  const Eigen::Isometry2d d = a.inverse() * b;
  return d.translation().norm() > params_.stationary_translation_m ||
         std::abs(HeadingOf(d)) > params_.stationary_rotation_rad;
}

const PoseRecord& PoseCorrector::latest() const {
  if (records_.empty()) throw std::logic_error("pose corrector: no key frame yet");
  return records_.back();
}

void PoseCorrector::Restore(std::vector<PoseRecord> records) {
  const auto rigid = [](const Eigen::Isometry2d& T) {
    const Eigen::Matrix2d R = T.linear();
    return T.matrix().allFinite() &&
           (R * R.transpose() - Eigen::Matrix2d::Identity()).norm() < 1e-6;
  };
  for (size_t i = 0; i < records.size(); ++i) {
    const auto& r = records[i];
    if (!rigid(r.T_world_base_odometry) || !rigid(r.T_world_base) ||
        !std::isfinite(r.visual_dtheta) || !std::isfinite(r.odometry_dtheta)) {
      throw std::invalid_argument("pose corrector: saved record " + std::to_string(i) +
                                  " is not a finite rigid pose");
    }
    if (i > 0 && r.stamp_ns <= records[i - 1].stamp_ns) {
      throw std::invalid_argument("pose corrector: saved stamps do not increase at record " +
                                  std::to_string(i));
    }
  }
  records_ = std::move(records);
}

const PoseRecord& PoseCorrector::Add(int64_t stamp_ns, const Eigen::Isometry2d& T_odom_base,
                                     std::optional<double> visual_dtheta) {
  if (!T_odom_base.matrix().allFinite()) {
    throw std::invalid_argument("pose corrector: odometry pose is not finite");
  }
  if (!records_.empty() && stamp_ns <= records_.back().stamp_ns) {
    throw std::invalid_argument("pose corrector: key frame stamp " + std::to_string(stamp_ns) +
                                " is not after the previous one (" +
                                std::to_string(records_.back().stamp_ns) + ")");
  }
  PoseRecord r;
  r.stamp_ns = stamp_ns;
  r.T_world_base_odometry = T_odom_base;
  if (records_.empty()) {
    r.T_world_base = T_odom_base;
    r.heading_source = HeadingSource::kStart;
    records_.push_back(r);
    return records_.back();
  }
  const PoseRecord& prev = records_.back();
  const Eigen::Isometry2d step = prev.T_world_base_odometry.inverse() * T_odom_base;
  const double dtheta_odo = HeadingOf(step);
  r.odometry_dtheta = dtheta_odo;
  double dtheta = dtheta_odo;
  if (!Moved(prev.T_world_base_odometry, T_odom_base)) {
    r.heading_source = HeadingSource::kStationary;
    dtheta = 0;
  } else if (visual_dtheta && std::isfinite(*visual_dtheta) &&
             std::abs(WrapAngle(*visual_dtheta - dtheta_odo)) <= params_.max_disagreement_rad) {
    r.heading_source = HeadingSource::kVisual;
    r.visual_dtheta = *visual_dtheta;
    dtheta = *visual_dtheta;
  } else {
    r.heading_source = HeadingSource::kOdometry;
  }
  // The odometry's translation in the previous base frame, as a chord at half the turn; the
  // corrected chord keeps its length and its angle to the corrected mid-heading.
  const Eigen::Vector2d chord = step.translation();
  const double theta_prev = HeadingOf(prev.T_world_base);
  const Eigen::Vector2d delta =
      Eigen::Rotation2Dd(theta_prev + 0.5 * (dtheta - dtheta_odo)) * chord;
  const double theta = WrapAngle(theta_prev + dtheta);
  const Eigen::Vector2d position = prev.T_world_base.translation() + delta;
  r.T_world_base = MakePose(position.x(), position.y(), theta);
  records_.push_back(r);
  return records_.back();
}

void PoseCorrector::ApplyTranslation(const Eigen::Vector2d& delta_world, size_t first_record) {
  if (!delta_world.allFinite()) {
    throw std::invalid_argument("pose corrector: translation correction is not finite");
  }
  for (size_t i = first_record; i < records_.size(); ++i) {
    records_[i].T_world_base.translation() += delta_world;
  }
}

void PoseCorrector::ApplyRotation(double dtheta, const Eigen::Vector2d& pivot_world,
                                  size_t first_record) {
  if (!std::isfinite(dtheta) || !pivot_world.allFinite()) {
    throw std::invalid_argument("pose corrector: rotation correction is not finite");
  }
  const Eigen::Isometry2d turn = Eigen::Translation2d(pivot_world) * Eigen::Rotation2Dd(dtheta) *
                                 Eigen::Translation2d(-pivot_world);
  for (size_t i = first_record; i < records_.size(); ++i) {
    const Eigen::Isometry2d T = turn * records_[i].T_world_base;
    // Rebuilt from x, y, theta so that repeated turns keep the rotation exactly orthonormal.
    records_[i].T_world_base =
        MakePose(T.translation().x(), T.translation().y(), WrapAngle(HeadingOf(T)));
  }
}

Eigen::Vector3d PoseCorrector::LatestDifference() const {
  const PoseRecord& r = latest();
  const Eigen::Vector2d dp = r.T_world_base.translation() - r.T_world_base_odometry.translation();
  return {dp.x(), dp.y(),
          WrapAngle(HeadingOf(r.T_world_base) - HeadingOf(r.T_world_base_odometry))};
}

}  // namespace epmap::localisation
