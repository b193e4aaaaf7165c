#include "services/mapping/calibration/stereo_job.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "perception/calibration/mixture.h"
#include "perception/calibration/stereo_self_calibration.h"

namespace epmap::mapping {

namespace {

using calibration::CalibrationError;
using calibration::ErrorCode;

constexpr double kDefaultMaxPriorDeviationDeg = 3.0;
constexpr uint32_t kMaxFrames = 1000;

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string Seconds(int64_t ns) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f s", static_cast<double>(ns) / 1e9);
  return buf;
}

}  // namespace

std::optional<calibration::CameraIntrinsics> IntrinsicsFromCameraInfo(
    const dds::CameraCalibration& c, std::string* reason) {
  calibration::CameraIntrinsics out;
  out.width = c.width;
  out.height = c.height;
  out.k = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(c.k.data());
  out.distortion = c.d;
  if (c.distortion_model == "plumb_bob" || c.distortion_model == "radial-tangential" ||
      c.distortion_model.empty()) {
    out.distortion_model = "radial-tangential";
  } else if (c.distortion_model == "equidistant") {
    out.distortion_model = "equidistant";
  } else {
    *reason = "CameraInfo distortion model '" + c.distortion_model +
              "' is not supported by the self-calibration (plumb_bob or equidistant)";
    return std::nullopt;
  }
  return out;
}

namespace {

const char* Advice(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInsufficientFeatures:
      return "point the cameras at a textured scene with things at several depths";
    case ErrorCode::kPlanarScene:
      return "the view is one plane or too far away: show the cameras a scene with depth";
    case ErrorCode::kRejectedByPrior:
      return "check the URDF and the eye encoders, or allow a larger max_prior_deviation_deg";
    default:
      return "see the message";
  }
}

struct Collected {
  StereoFrame frame;
  Eigen::Isometry3d prior;
  calibration::CameraIntrinsics cam0, cam1;
};

}  // namespace

v1::StereoExtrinsicsSpec WithDefaults(v1::StereoExtrinsicsSpec spec,
                                      const CalibrationSettings& settings) {
  if (spec.frames() == 0) spec.set_frames(settings.stereo_frames);
  if (spec.max_prior_deviation_deg() == 0) {
    spec.set_max_prior_deviation_deg(kDefaultMaxPriorDeviationDeg);
  }
  if (spec.frame_timeout_ms() == 0) {
    spec.set_frame_timeout_ms(static_cast<uint32_t>(settings.stereo_frame_timeout_ns / 1'000'000));
  }
  if (spec.frame_interval_ms() == 0) {
    spec.set_frame_interval_ms(
        static_cast<uint32_t>(settings.stereo_frame_interval_ns / 1'000'000));
  }
  return spec;
}

std::string CheckStereoSpec(const v1::StereoExtrinsicsSpec& spec) {
  if (spec.frames() > kMaxFrames) {
    return "stereo_extrinsics.frames must be at most " + std::to_string(kMaxFrames);
  }
  if (!(spec.max_prior_deviation_deg() >= 0 && spec.max_prior_deviation_deg() <= 45)) {
    return "stereo_extrinsics.max_prior_deviation_deg must be in (0, 45] (0 = 3)";
  }
  if (spec.frame_timeout_ms() > 3'600'000) {
    return "stereo_extrinsics.frame_timeout_ms must be at most one hour";
  }
  return "";
}

StereoJobResult RunStereoJob(const v1::StereoExtrinsicsSpec& spec_in,
                             const StereoJobEnvironment& env,
                             const calibration::ProgressCallback& progress) {
  const auto spec = WithDefaults(spec_in, env.settings);
  if (!env.chain) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           "the stereo-extrinsics job needs the head's kinematics for its prior: "
                           "start epmapd with --urdf FILE (a URDF with both cameras' optical "
                           "links, robot.left_camera_link and robot.right_camera_link)");
  }
  if (!env.chain->has_cam1()) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           "the URDF " + env.urdf_path + " has no link named '" +
                               env.chain->camera_links().right +
                               "' (robot.right_camera_link): the stereo-extrinsics job needs the "
                               "chain to both cameras for its kinematic prior");
  }
  const int n = static_cast<int>(spec.frames());
  const auto timeout = std::chrono::milliseconds(spec.frame_timeout_ms());

  // 1. Collect n frames, each with its intrinsics and its kinematic prior.
  std::vector<Collected> frames;
  std::map<std::string, int> unusable;
  auto subscription =
      env.tap->Subscribe(static_cast<int64_t>(spec.frame_interval_ms()) * 1'000'000);
  const auto waiting = [&] {
    return calibration::Progress{"waiting for frames", frames.size(), 0.0,
                                 0.2 * static_cast<double>(frames.size()) / n};
  };
  const auto keep_waiting = [&] { return !progress || progress(waiting()); };
  calibration::ReportProgress(progress, waiting());
  while (static_cast<int>(frames.size()) < n) {
    auto frame = subscription->Next(timeout, keep_waiting);
    calibration::ReportProgress(progress, waiting());  // throws kCancelled if asked to stop
    if (!frame) {
      throw CalibrationError(
          ErrorCode::kInvalidInput,
          frames.empty() && unusable.empty()
              ? "no stereo frames arrived within " + Seconds(timeout.count() * 1'000'000) +
                    ": is a stereo camera publishing raw images (" + env.image_topics +
                    ") on DDS domain " + std::to_string(env.dds_domain) + "?"
              : "only " + std::to_string(frames.size()) + " of " + std::to_string(n) +
                    " usable frames before the stream paused for " +
                    Seconds(timeout.count() * 1'000'000));
    }
    std::string reason;
    const auto infos = env.sensors->camera_infos();
    std::optional<calibration::CameraIntrinsics> c0, c1;
    if (!infos.left || !infos.right) {
      reason = "no CameraInfo for both cameras yet (K and D are needed)";
    } else {
      c0 = IntrinsicsFromCameraInfo(*infos.left, &reason);
      if (c0) c1 = IntrinsicsFromCameraInfo(*infos.right, &reason);
    }
    if (c0 && c1 &&
        (frame->left.cols != c0->width || frame->left.rows != c0->height ||
         frame->right.cols != c1->width || frame->right.rows != c1->height)) {
      reason = "the images' size differs from the CameraInfo's";
    }
    std::optional<std::vector<double>> joints;
    if (reason.empty()) {
      std::string why;
      joints =
          env.sensors->JointsAt(frame->stamp_ns, env.chain->joint_names(), env.joints_max_gap_ns,
                                std::chrono::nanoseconds(env.joints_wait_ns), &why);
      if (!joints) reason = "no joint reading at the frame's stamp (" + why + ")";
    }
    if (!reason.empty()) {
      // Frames keep coming but none can be used: say why instead of waiting forever.
      if (++unusable[reason] > 2 * n + 10) {
        throw CalibrationError(
            ErrorCode::kInvalidInput,
            std::to_string(unusable[reason]) + " frames could not be used: " + reason);
      }
      continue;
    }
    frames.push_back(
        {std::move(*frame), calibration::KinematicPrior(*env.chain, *joints), *c0, *c1});
  }
  subscription.reset();

  // 2. Self-calibrate each frame; its correction to its own prior.
  calibration::StereoSelfCalibrationParams params;
  params.max_rotation_deviation_deg = spec.max_prior_deviation_deg();
  params.max_baseline_direction_deviation_deg = spec.max_prior_deviation_deg();
  params.baseline_direction_prior_sigma_deg = env.settings.baseline_direction_prior_sigma_deg;
  std::vector<Eigen::Isometry3d> corrections;
  std::vector<const Collected*> used;
  std::map<ErrorCode, std::pair<int, std::string>> failures;
  int inliers = 0;
  for (int i = 0; i < n; ++i) {
    const Collected& c = frames[static_cast<size_t>(i)];
    calibration::StereoView view;
    view.left = c.frame.left;
    view.right = c.frame.right;
    view.T_cam0_cam1_prior = c.prior;
    view.stamp_ns = c.frame.stamp_ns;
    const auto sub =
        calibration::ProgressSubrange(progress, 0.2 + 0.65 * i / n, 0.2 + 0.65 * (i + 1) / n);
    try {
      const auto r = calibration::SelfCalibrateStereo(c.cam0, c.cam1, {view}, params, sub);
      corrections.push_back(CorrectionOf(c.prior, r.model.T_cam0_cam1));
      used.push_back(&c);
      inliers += r.model.inliers;
      spdlog::debug(
          "stereo job frame {}: {} inliers, rms {:.3f} px, {:.3f} deg / {:.3f} deg from the prior",
          i, r.model.inliers, r.model.rms_sampson_px, r.model.rotation_deviation_deg,
          r.model.baseline_direction_deviation_deg);
    } catch (const CalibrationError& e) {
      if (e.code() == ErrorCode::kCancelled) throw;
      spdlog::debug("stereo job frame {}: {}", i, e.what());
      auto& f = failures[e.code()];
      if (f.first++ == 0) f.second = e.what();
    }
  }
  const int need =
      std::max(1, static_cast<int>(std::ceil(env.settings.stereo_min_success_share * n)));
  if (static_cast<int>(corrections.size()) < need) {
    ErrorCode worst = ErrorCode::kInsufficientFeatures;
    int most = 0;
    std::string detail;
    for (const auto& [code, f] : failures) {
      if (f.first > most) {
        most = f.first;
        worst = code;
      }
      detail += std::string(detail.empty() ? "" : "; ") + std::to_string(f.first) + "x " +
                calibration::ToString(code) + " (" + f.second + ")";
    }
    throw CalibrationError(worst, "stereo self-calibration succeeded on " +
                                      std::to_string(corrections.size()) + " of " +
                                      std::to_string(n) + " frames (need " + std::to_string(need) +
                                      "): " + detail + ". " + Advice(worst));
  }

  // 3. Combine and measure.
  StereoJobResult out;
  auto& m = out.model;
  m.correction = MedianCorrection(corrections);
  m.T_cam0_cam1_reference = m.Apply(used.front()->prior);
  m.frames_used = static_cast<int>(used.size());
  m.frames_failed = n - m.frames_used;
  m.correction_rotation_deg = Eigen::AngleAxisd(m.correction.linear()).angle() * 180.0 / M_PI;
  m.correction_translation_m = m.correction.translation().norm();
  m.inliers = inliers;
  m.baseline_direction_prior_sigma_deg = params.baseline_direction_prior_sigma_deg;
  std::vector<double> spread, direction, offset, prior_offset;
  for (size_t i = 0; i < used.size(); ++i) {
    calibration::ReportProgress(progress, {"measuring", i, 0.0, 0.85 + 0.15 * i / used.size()});
    const Collected& c = *used[i];
    const Eigen::Isometry3d T = m.Apply(c.prior);
    spread.push_back(RotationDifferenceDeg(corrections[i], m.correction));
    direction.push_back(calibration::DirectionAngleDeg(c.prior.translation(), T.translation()));
    offset.push_back(calibration::MedianRowOffset(c.cam0, c.cam1, T, c.frame.left, c.frame.right));
    prior_offset.push_back(
        calibration::MedianRowOffset(c.cam0, c.cam1, c.prior, c.frame.left, c.frame.right));
  }
  m.spread_deg = Median(spread);
  m.median_vertical_offset_px = Median(offset);
  m.prior_median_vertical_offset_px = Median(prior_offset);

  auto& e = out.errors;
  e.set_prior_rotation_deviation_deg(m.correction_rotation_deg);
  e.set_prior_baseline_deviation_deg(Median(direction));
  e.set_median_vertical_offset_px(m.median_vertical_offset_px);
  e.set_prior_median_vertical_offset_px(m.prior_median_vertical_offset_px);
  e.set_inlier_matches(static_cast<uint32_t>(inliers));
  e.set_frames_used(static_cast<uint32_t>(m.frames_used));
  e.set_frames_failed(static_cast<uint32_t>(m.frames_failed));
  e.set_correction_spread_deg(m.spread_deg);

  char buf[256];
  std::snprintf(
      buf, sizeof buf,
      "correction to the kinematic prior: %.3f deg, %.2f mm (median of %d frames, "
      "%d refused); baseline-direction prior %s",
      m.correction_rotation_deg, 1000 * m.correction_translation_m, m.frames_used, m.frames_failed,
      m.baseline_direction_prior_sigma_deg > 0
          ? ("sigma " + std::to_string(m.baseline_direction_prior_sigma_deg) + " deg").c_str()
          : "off");
  out.description = buf;
  return out;
}

}  // namespace epmap::mapping
