#pragma once
// Paper 002, Sec. 2: the pose estimate of the robot. Between key frames the odometry's
// translation is kept but its heading change is replaced by the visual estimate (the vertical
// rotation of the Lorentzian registration); at each panning stop the translation found by
// correlating the local map with the global one is added. World frame = the robot's start pose
// (= the odometry's start frame).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace epmap::localisation {

enum class HeadingSource {
  kStart,       // the first key frame
  kStationary,  // the base did not move: nothing to correct
  kVisual,      // the visual heading change was used
  kOdometry,    // the visual estimate was missing or refused: odometry's change kept
};
const char* ToString(HeadingSource s);

struct PoseRecord {
  int64_t stamp_ns = 0;
  Eigen::Isometry2d T_world_base_odometry = Eigen::Isometry2d::Identity();
  Eigen::Isometry2d T_world_base = Eigen::Isometry2d::Identity();  // corrected
  HeadingSource heading_source = HeadingSource::kStart;
  double visual_dtheta = 0;    // rad, when used
  double odometry_dtheta = 0;  // rad
};

struct PoseCorrectorParams {
  // Below these the base is taken as stationary between two key frames (a panning stop).
  double stationary_translation_m = 0.005;
  double stationary_rotation_rad = 0.002;
  // A visual heading change this far from the odometry's over one key frame step is refused
  // (odometry drifts slowly; a large disagreement is a failed registration).
  double max_disagreement_rad = 0.26;  // 15 degrees
  void Validate() const;
};

class PoseCorrector {
 public:
  explicit PoseCorrector(const PoseCorrectorParams& params = {});

  // True if the base moved between two odometry poses (by the thresholds above).
  bool Moved(const Eigen::Isometry2d& T_odom_a, const Eigen::Isometry2d& T_odom_b) const;

  // Adds a key frame. visual_dtheta: the visual heading change since the previous key frame
  // (counter-clockwise, rad), if the registration succeeded. Throws std::invalid_argument on a
  // non-finite pose or a stamp not after the previous one.
  const PoseRecord& Add(int64_t stamp_ns, const Eigen::Isometry2d& T_odom_base,
                        std::optional<double> visual_dtheta);

  // Adds a translation found by map correlation to the estimates from record first_record on
  // (the key frames of the stop that was registered); later key frames build on them.
  void ApplyTranslation(const Eigen::Vector2d& delta_world, size_t first_record);
  // Turns the estimates from record first_record on by dtheta (counter-clockwise, rad) about
  // the world point pivot: a heading correction found by map registration at a stop.
  void ApplyRotation(double dtheta, const Eigen::Vector2d& pivot_world, size_t first_record);

  // Takes over saved records (a resumed map): stamps increasing, poses finite and rigid, or
  // std::invalid_argument and the corrector unchanged.
  void Restore(std::vector<PoseRecord> records);

  bool empty() const { return records_.empty(); }
  const PoseRecord& latest() const;
  const std::vector<PoseRecord>& records() const { return records_; }
  // The records, moved out of a corrector that is done with (a provisional copy): one copy of
  // the whole run less per snapshot.
  std::vector<PoseRecord> TakeRecords() && { return std::move(records_); }
  // Corrected minus odometry pose of the latest key frame (x, y, theta wrapped to (-pi, pi]).
  Eigen::Vector3d LatestDifference() const;

 private:
  PoseCorrectorParams params_;
  std::vector<PoseRecord> records_;
};

// Planar helpers.
double HeadingOf(const Eigen::Isometry2d& T);
double WrapAngle(double a);  // to (-pi, pi]
Eigen::Isometry2d MakePose(double x, double y, double theta);

}  // namespace epmap::localisation
