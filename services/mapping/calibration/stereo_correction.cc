#include "services/mapping/calibration/stereo_correction.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "perception/calibration/json_lite.h"

namespace epmap::mapping {

namespace json = calibration::json;

namespace {

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

json::Value Pose(const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  json::Value pose = json::Value::Object();
  pose.Set("p", json::Value::Numbers(T.translation().data(), 3));
  const double qv[4] = {q.w(), q.x(), q.y(), q.z()};
  pose.Set("q_wxyz", json::Value::Numbers(qv, 4));
  return pose;
}

Eigen::Isometry3d ReadPose(const json::Value& pose, const std::string& what) {
  const auto p = pose.Get("p").AsNumbers(3, what + ".p");
  const auto q = pose.Get("q_wxyz").AsNumbers(4, what + ".q_wxyz");
  const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  if (!(std::abs(quat.norm() - 1.0) < 1e-6)) {
    throw std::runtime_error(what + ".q_wxyz is not a unit quaternion");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = quat.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  if (!T.matrix().allFinite()) throw std::runtime_error(what + " is not finite");
  return T;
}

}  // namespace

Eigen::Isometry3d CorrectionOf(const Eigen::Isometry3d& T_cam0_cam1_prior,
                               const Eigen::Isometry3d& T_cam0_cam1_estimated) {
  return T_cam0_cam1_prior.inverse() * T_cam0_cam1_estimated;
}

Eigen::Isometry3d MedianCorrection(const std::vector<Eigen::Isometry3d>& corrections) {
  if (corrections.empty()) throw std::invalid_argument("no corrections to combine");
  Eigen::Vector3d w, t;
  for (int k = 0; k < 3; ++k) {
    std::vector<double> wk, tk;
    for (const auto& c : corrections) {
      const Eigen::AngleAxisd aa(c.linear());
      wk.push_back((aa.angle() * aa.axis())(k));
      tk.push_back(c.translation()(k));
    }
    w(k) = Median(wk);
    t(k) = Median(tk);
  }
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  if (w.norm() > 0) out.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  out.translation() = t;
  return out;
}

double RotationDifferenceDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

std::string StereoCorrectionModel::ToJson() const {
  json::Value root = json::Value::Object();
  root.Set("type", json::Value::String("stereo-extrinsics-correction"));
  root.Set("format_version", json::Value::Number(1));
  root.Set("correction_T_cam1prior_cam1", Pose(correction));
  root.Set("T_cam0_cam1_reference", Pose(T_cam0_cam1_reference));
  root.Set("frames_used", json::Value::Number(frames_used));
  root.Set("frames_failed", json::Value::Number(frames_failed));
  root.Set("correction_rotation_deg", json::Value::Number(correction_rotation_deg));
  root.Set("correction_translation_m", json::Value::Number(correction_translation_m));
  root.Set("spread_deg", json::Value::Number(spread_deg));
  root.Set("median_vertical_offset_px", json::Value::Number(median_vertical_offset_px));
  root.Set("prior_median_vertical_offset_px", json::Value::Number(prior_median_vertical_offset_px));
  root.Set("inliers", json::Value::Number(inliers));
  root.Set("baseline_direction_prior_sigma_deg",
           json::Value::Number(baseline_direction_prior_sigma_deg));
  return json::Write(root);
}

StereoCorrectionModel StereoCorrectionModel::FromJson(std::string_view text) {
  try {
    const json::Value root = json::Parse(text);
    if (root.Get("type").AsString("type") != "stereo-extrinsics-correction") {
      throw std::runtime_error("not a stereo-extrinsics-correction model");
    }
    if (root.Get("format_version").AsNumber("format_version") != 1) {
      throw std::runtime_error("unsupported format_version");
    }
    StereoCorrectionModel m;
    m.correction = ReadPose(root.Get("correction_T_cam1prior_cam1"), "correction_T_cam1prior_cam1");
    m.T_cam0_cam1_reference = ReadPose(root.Get("T_cam0_cam1_reference"), "T_cam0_cam1_reference");
    const auto number = [&](const char* key) { return root.Get(key).AsNumber(key); };
    m.frames_used = static_cast<int>(number("frames_used"));
    m.frames_failed = static_cast<int>(number("frames_failed"));
    m.correction_rotation_deg = number("correction_rotation_deg");
    m.correction_translation_m = number("correction_translation_m");
    m.spread_deg = number("spread_deg");
    m.median_vertical_offset_px = number("median_vertical_offset_px");
    m.prior_median_vertical_offset_px = number("prior_median_vertical_offset_px");
    m.inliers = static_cast<int>(number("inliers"));
    m.baseline_direction_prior_sigma_deg = number("baseline_direction_prior_sigma_deg");
    return m;
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("cannot read stereo-extrinsics model: ") + e.what());
  }
}

}  // namespace epmap::mapping
