#include "perception/mobile_mapping/mobile_mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace epmap::mobile_mapping {

namespace {

Eigen::Isometry3d To3d(const Eigen::Isometry2d& T) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear().topLeftCorner<2, 2>() = T.linear();
  out.translation().head<2>() = T.translation();
  return out;
}

std::string Fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

cv::Mat GrowMovingMask(const cv::Mat& mask) {
  cv::Mat grown;
  const int k = 2 * kMovingMaskGrowPx + 1;
  cv::dilate(mask, grown, cv::getStructuringElement(cv::MORPH_RECT, {k, k}));
  return grown;
}

std::optional<Eigen::Vector3d> TrueDepthOf(const cv::Mat& true_disparity,
                                           const stereo::RectifiedGeometry& camera, float u,
                                           float v) {
  const int x = static_cast<int>(std::lround(u)), y = static_cast<int>(std::lround(v));
  if (x < 0 || y < 0 || x >= true_disparity.cols || y >= true_disparity.rows) return {};
  const float d = true_disparity.at<float>(y, x);
  if (!std::isfinite(d) || d <= 0) return {};
  float lo = d, hi = d;
  for (int yy = std::max(0, y - kTrueDepthEdgePx);
       yy <= std::min(true_disparity.rows - 1, y + kTrueDepthEdgePx); ++yy) {
    for (int xx = std::max(0, x - kTrueDepthEdgePx);
         xx <= std::min(true_disparity.cols - 1, x + kTrueDepthEdgePx); ++xx) {
      const float n = true_disparity.at<float>(yy, xx);
      if (!std::isfinite(n) || n <= 0) return {};  // beside the unknown (sky, far): ambiguous
      lo = std::min(lo, n);
      hi = std::max(hi, n);
    }
  }
  if (hi - lo > kTrueDepthEdgeSpreadPx) return {};
  return localisation::Backproject(camera, {u, v}, d);
}

void MobileMapperParams::Validate() const {
  edges.Validate();
  perceptual.Validate();
  grid.Validate();
  measurement.Validate();
  features.Validate();
  registration.Validate();
  pose.Validate();
  if (!(odometry_drift_per_m >= 0) || !std::isfinite(odometry_drift_per_m)) {
    throw std::invalid_argument("mobile mapper: odometry_drift_per_m must be >= 0 and finite");
  }
  if (!(correlation_sigma_cells > 0) || !std::isfinite(correlation_sigma_cells)) {
    throw std::invalid_argument("mobile mapper: correlation_sigma_cells must be > 0 and finite");
  }
  if (!std::isfinite(floor_z_in_base_m)) {
    throw std::invalid_argument("mobile mapper: floor_z_in_base_m must be finite");
  }
  if (!(reference_max_height_m > reference_min_height_m)) {
    throw std::invalid_argument("mobile mapper: reference_max_height_m must exceed the minimum");
  }
  if (!std::isfinite(reference_skip_from_height_m) || !std::isfinite(reference_skip_to_height_m)) {
    throw std::invalid_argument("mobile mapper: the skipped reference height band must be finite");
  }
  if (occupancy_edge_row_step < 1) {
    throw std::invalid_argument("mobile mapper: occupancy_edge_row_step must be >= 1");
  }
  if (!(correlation_search_m >= 0) || !(correlation_min_gain >= 0)) {
    throw std::invalid_argument("mobile mapper: correlation search and gain must be >= 0");
  }
  if (!(correlation_heading_step_rad >= 0 && correlation_heading_step_rad < 0.2)) {
    throw std::invalid_argument(
        "mobile mapper: correlation_heading_step_rad must be in [0, 0.2) (0 = off)");
  }
  if (!(correlation_heading_sigma_rad > 0) || !std::isfinite(correlation_heading_sigma_rad) ||
      !(heading_drift_rad_per_m >= 0) || !std::isfinite(heading_drift_rad_per_m) ||
      !(heading_drift_per_rad >= 0) || !std::isfinite(heading_drift_per_rad)) {
    throw std::invalid_argument(
        "mobile mapper: correlation_heading_sigma_rad must be > 0, heading_drift_rad_per_m and "
        "heading_drift_per_rad >= 0, all finite");
  }
  if (!(head_still_rad >= 0))
    throw std::invalid_argument("mobile mapper: head_still_rad must be >= 0");
  if (view_min_key_frames < 0) {
    throw std::invalid_argument("mobile mapper: view_min_key_frames must be >= 0 (0 = automatic)");
  }
  if (!(max_odometry_step_m > 0) || !(max_odometry_step_rad > 0) || !(max_odometry_speed_mps > 0)) {
    throw std::invalid_argument("mobile mapper: odometry limits must be > 0");
  }
  for (const auto& j : joint_limits) {
    if (!(j.upper >= j.lower)) {
      throw std::invalid_argument("mobile mapper: joint '" + j.name + "' has upper < lower");
    }
  }
}

MobileMapper::MobileMapper(const stereo::RectifiedGeometry& camera,
                           const MobileMapperParams& params)
    : camera_(camera),
      params_(params),
      tracker_(camera, params.features),
      poses_(params.pose),
      perceptual_(params.perceptual),
      grid_(params.grid) {
  params_.Validate();
  perceptual_map::ValidateCamera(camera_);
  if (camera_.width <= 0 || camera_.height <= 0) {
    throw std::invalid_argument("mobile mapper: the camera needs its image size");
  }
  image_size_ = cv::Size(camera_.width, camera_.height);
}

std::optional<Rejection> MobileMapper::Check(const KeyFrame& f) const {
  if (f.left.empty() || f.right.empty()) {
    return Rejection{"image_missing", "key frame " + std::to_string(f.stamp_ns) +
                                          " has an empty left or right image"};
  }
  if (f.left.size() != image_size_ || f.right.size() != image_size_ ||
      f.left.type() != f.right.type()) {
    return Rejection{"image_size", "key frame images are " + std::to_string(f.left.cols) + "x" +
                                       std::to_string(f.left.rows) + " / " +
                                       std::to_string(f.right.cols) + "x" +
                                       std::to_string(f.right.rows) + ", the camera is " +
                                       std::to_string(image_size_.width) + "x" +
                                       std::to_string(image_size_.height)};
  }
  if (!f.moving.empty() && (f.moving.type() != CV_8UC1 || f.moving.size() != image_size_)) {
    return Rejection{"moving_mask_size", "the moving mask is not CV_8UC1 of the images' size"};
  }
  if (!f.true_disparity.empty() &&
      (f.true_disparity.type() != CV_32FC1 || f.true_disparity.size() != image_size_)) {
    return Rejection{"true_disparity_size",
                     "the true disparity is not CV_32FC1 of the images' size"};
  }
  if (!f.T_odom_base.matrix().allFinite()) {
    return Rejection{"odometry_not_finite", "the odometry pose holds NaN or infinity"};
  }
  const Eigen::Matrix3d R = f.T_base_cam.linear();
  if (!f.T_base_cam.matrix().allFinite() ||
      (R * R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-6) {
    return Rejection{"camera_pose_invalid",
                     "T_base_cam is not a finite rigid transform (check the kinematic chain)"};
  }
  if (!f.joint_positions.empty() && !params_.joint_limits.empty()) {
    if (f.joint_positions.size() != params_.joint_limits.size()) {
      return Rejection{"joint_count", "key frame has " + std::to_string(f.joint_positions.size()) +
                                          " joint readings, the limits name " +
                                          std::to_string(params_.joint_limits.size())};
    }
    for (size_t i = 0; i < f.joint_positions.size(); ++i) {
      const auto& lim = params_.joint_limits[i];
      const double q = f.joint_positions[i];
      if (!std::isfinite(q) || q < lim.lower - 1e-6 || q > lim.upper + 1e-6) {
        return Rejection{"joint_out_of_range", "joint '" + lim.name + "' reads " + Fmt(q) +
                                                   ", outside its limits [" + Fmt(lim.lower) +
                                                   ", " + Fmt(lim.upper) + "]"};
      }
    }
  }
  if (!poses_.empty()) {
    if (f.stamp_ns <= last_stamp_ns_) {
      return Rejection{"stamp_not_increasing", "key frame stamp " + std::to_string(f.stamp_ns) +
                                                   " ns is not after the previous key frame's " +
                                                   std::to_string(last_stamp_ns_) + " ns"};
    }
    const Eigen::Isometry2d step = poses_.latest().T_world_base_odometry.inverse() * f.T_odom_base;
    const double dist = step.translation().norm();
    const double turn = std::abs(localisation::HeadingOf(step));
    const double dt = 1e-9 * static_cast<double>(f.stamp_ns - last_stamp_ns_);
    if (dist > params_.max_odometry_step_m || turn > params_.max_odometry_step_rad ||
        dist / dt > params_.max_odometry_speed_mps) {
      return Rejection{"odometry_jump", "odometry moved " + Fmt(dist) + " m and " + Fmt(turn) +
                                            " rad in " + Fmt(dt) +
                                            " s since the previous key frame (limits " +
                                            Fmt(params_.max_odometry_step_m) + " m, " +
                                            Fmt(params_.max_odometry_step_rad) + " rad, " +
                                            Fmt(params_.max_odometry_speed_mps) + " m/s)"};
    }
  }
  return std::nullopt;
}

void MobileMapper::ClearMaps() {
  poses_ = localisation::PoseCorrector(params_.pose);
  perceptual_ = perceptual_map::PerceptualMapper(params_.perceptual);
  grid_ = occupancy::LayeredGrid(params_.grid);
  previous_features_.reset();
  seen_panning_stop_ = false;
  group_ = Group{};
  filter_ = PositionFilter{};
  counters_ = MapperCounters{};
  last_stamp_ns_ = 0;
  restore_unconfirmed_ = false;
}

KeyFrameReport MobileMapper::AddKeyFrame(const KeyFrame& f) {
  KeyFrameReport report;
  auto rejection = Check(f);
  if (restore_unconfirmed_) {
    // The first key frame after a restore: does it continue the saved run? If not, the maps
    // start anew and it is checked again, as the first key frame of new maps.
    if (rejection &&
        (rejection->reason == "stamp_not_increasing" || rejection->reason == "odometry_jump")) {
      report.restored_maps_dropped = rejection->message;
      ClearMaps();
      rejection = Check(f);
    } else if (!rejection) {
      restore_unconfirmed_ = false;
    }
  }
  if (rejection) {
    ++counters_.rejected;
    ++counters_.rejected_by_reason[rejection->reason];
    report.rejection = std::move(rejection);
    return report;
  }

  // Measurements of this key frame (nothing in the maps changes yet). While the head stands
  // still, its encoder noise must not become heading noise: a camera pose that differs from
  // the previous key frame's by less than head_still_rad is taken as the same.
  Eigen::Isometry3d T_base_cam_heading = f.T_base_cam;
  if (previous_features_) {
    const Eigen::AngleAxisd change(previous_features_->T_base_cam.linear().transpose() *
                                   f.T_base_cam.linear());
    if (std::abs(change.angle()) < params_.head_still_rad) {
      T_base_cam_heading = previous_features_->T_base_cam;
    }
    // A panning stop: the head turned while the base stood (the thresholds epmap-bench maps
    // uses to detect panning stops in a whole dataset).
    if (!poses_.empty() && std::abs(change.angle()) > 0.05 &&
        (poses_.latest().T_world_base_odometry.inverse() * f.T_odom_base).translation().norm() <
            0.005) {
      seen_panning_stop_ = true;
    }
  }
  localisation::KeyFrameFeatures features = tracker_.Detect(f.left, f.right, T_base_cam_heading);
  auto edges = perceptual_map::MatchEdgePoints(f.left, f.right, camera_, params_.edges);
  if (!f.moving.empty()) {
    const auto moves = [&](float u, float v) {
      const int x = static_cast<int>(u + 0.5F), y = static_cast<int>(v + 0.5F);
      return x >= 0 && y >= 0 && x < f.moving.cols && y < f.moving.rows &&
             f.moving.at<uint8_t>(y, x) != 0;
    };
    std::erase_if(features.features,
                  [&](const localisation::StereoFeature& s) { return moves(s.left.x, s.left.y); });
    std::erase_if(edges, [&](const perceptual_map::EdgePoint& e) { return moves(e.u, e.v); });
  }
  report.features = features.features.size();
  report.edge_points = edges.size();
  FramePoints frame;
  frame.camera_in_base = f.T_base_cam.translation();
  // A map point's position in the camera: the stereo's, or the true one under evaluation.
  const auto map_point = [&](float u, float v, const Eigen::Vector3d& p_cam) {
    if (f.true_disparity.empty()) return p_cam;
    return TrueDepthOf(f.true_disparity, camera_, u, v).value_or(p_cam);
  };
  for (const auto& e : edges) {
    const Eigen::Vector3d p_cam = map_point(e.u, e.v, e.p_cam);
    const Eigen::Vector3d p = f.T_base_cam * p_cam;
    const double h = p.z() - params_.floor_z_in_base_m;
    const bool in_skipped_band =
        h > params_.reference_skip_from_height_m && h < params_.reference_skip_to_height_m;
    if (h >= params_.reference_min_height_m && h <= params_.reference_max_height_m &&
        !in_skipped_band) {
      frame.reference_points.emplace_back(p.x(), p.y());
    }
    if (static_cast<int>(e.v) % params_.occupancy_edge_row_step == 0 &&
        e.slope <= params_.occupancy_edge_max_slope) {
      frame.points_base.push_back(p);
      frame.sigmas.push_back(localisation::DepthSigma(camera_, p_cam.z(),
                                                      params_.features.disparity_sigma_px,
                                                      params_.features.min_point_sigma_m));
    }
  }
  report.reference_points = frame.reference_points.size();
  for (const auto& s : features.features) {
    if (!params_.occupancy_feature_points) break;
    const Eigen::Vector3d p_cam = map_point(s.left.x, s.left.y, s.p_cam);
    frame.points_base.push_back(f.T_base_cam * p_cam);
    frame.sigmas.push_back(localisation::DepthSigma(camera_, p_cam.z(),
                                                    params_.features.disparity_sigma_px,
                                                    params_.features.min_point_sigma_m));
  }

  // The stop is over when the base moves on: close it at its own pose first.
  if (group_.open && poses_.Moved(group_.T_odom_base, f.T_odom_base)) CloseGroup(&report);

  // Heading: the motion since the previous key frame from the tracked features (Sec. 3.3).
  std::optional<double> visual_dtheta;
  if (!poses_.empty() && params_.visual_heading && previous_features_ &&
      poses_.Moved(poses_.latest().T_world_base_odometry, f.T_odom_base)) {
    const Eigen::Isometry3d predicted =
        To3d(f.T_odom_base.inverse() * poses_.latest().T_world_base_odometry);
    const auto pairs = tracker_.Track(*previous_features_, features, predicted);
    report.tracked_pairs = pairs.x_prev.size();
    const auto fit =
        params_.step_translation_from_odometry
            ? localisation::RegisterLorentzianRotation(pairs.x_prev, pairs.x_cur, pairs.sigma,
                                                       predicted.inverse().translation(),
                                                       predicted.linear(), params_.registration)
            : localisation::RegisterLorentzian(pairs.x_prev, pairs.x_cur, pairs.sigma, predicted,
                                               params_.registration);
    report.registration_inliers = fit.inliers;
    // T_cur_prev rotates static points by minus the base's turn.
    if (fit.ok) visual_dtheta = -localisation::YawOf(fit.T.linear());
  }
  const auto& record = poses_.Add(f.stamp_ns, f.T_odom_base, visual_dtheta);
  report.heading_source = record.heading_source;
  if (record.heading_source == localisation::HeadingSource::kVisual) ++counters_.visual_heading;
  if (record.heading_source == localisation::HeadingSource::kOdometry) ++counters_.odometry_heading;
  previous_features_ = std::move(features);
  last_stamp_ns_ = f.stamp_ns;
  ++counters_.key_frames;

  if (!group_.open) {
    group_.open = true;
    group_.T_odom_base = f.T_odom_base;
    group_.first_record = poses_.records().size() - 1;
    group_.frames.clear();
  }
  group_.frames.push_back(std::move(frame));
  report.accepted = true;
  return report;
}

void MobileMapper::Flush() {
  KeyFrameReport ignored;
  if (group_.open) CloseGroup(&ignored);
}

int MobileMapper::MinKeyFramesForView() const {
  return params_.view_min_key_frames > 0 ? params_.view_min_key_frames : seen_panning_stop_ ? 2 : 1;
}

void MobileMapper::CloseGroup(KeyFrameReport* report) {
  group_.open = false;
  report->group_closed = true;
  ++counters_.groups;
  if (static_cast<int>(group_.frames.size()) < MinKeyFramesForView()) {
    ++counters_.groups_too_short;
    group_.frames.clear();
    return;
  }
  MergeGroup(group_, {grid_, perceptual_, poses_, counters_, filter_}, report);
  group_.frames.clear();
}

void MobileMapper::MergeGroup(const Group& group, MapsState state, KeyFrameReport* report) const {
  // The stop's pose: every key frame of the group stands there (the latest record is its last).
  const Eigen::Isometry3d T_world_base = To3d(state.poses.latest().T_world_base);
  Eigen::Isometry3d T_floor = Eigen::Isometry3d::Identity();
  T_floor.translation().z() = -params_.floor_z_in_base_m;  // world z = height above the floor

  const Eigen::Vector2d stop_xy = T_world_base.translation().head<2>();
  const double stop_heading = localisation::HeadingOf(state.poses.latest().T_world_base);
  // Local occupancy map of the stop, in the world frame at the current pose estimate turned
  // by `turn` (rad) about the stop.
  const auto local_map = [&](double turn) {
    Eigen::Isometry3d R = Eigen::Isometry3d::Identity();
    R.linear() = Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d pivot(stop_xy.x(), stop_xy.y(), 0.0);
    R.translation() = pivot - R.linear() * pivot;
    const Eigen::Isometry3d T_turned = T_floor * R * T_world_base;
    occupancy::LayeredGrid local(params_.grid);
    for (const auto& fp : group.frames) {
      const Eigen::Vector3d origin = T_turned * fp.camera_in_base;
      for (size_t i = 0; i < fp.points_base.size(); ++i) {
        local.AddPoint(origin, T_turned * fp.points_base[i], fp.sigmas[i], params_.measurement);
      }
    }
    return local;
  };
  occupancy::LayeredGrid local = local_map(0.0);
  // Odometry may have drifted since the previous stop by a share of the distance driven.
  if (state.filter.last_stop) {
    const double driven = (stop_xy - *state.filter.last_stop).norm();
    const double drift = params_.odometry_drift_per_m * driven;
    state.filter.variance += Eigen::Vector2d::Constant(drift * drift);
    // The visual heading errs most while the base turns (a turn into a room).
    const double turned =
        std::abs(localisation::WrapAngle(stop_heading - state.filter.last_stop_heading));
    const double heading_drift =
        params_.heading_drift_rad_per_m * driven + params_.heading_drift_per_rad * turned;
    state.filter.heading_variance += heading_drift * heading_drift;
  }
  state.filter.last_stop = stop_xy;
  state.filter.last_stop_heading = stop_heading;
  int sx = 0, sy = 0;
  if (!state.grid.empty() && params_.map_correlation) {
    const auto reg = occupancy::CorrelateMaps(local, state.grid, params_.correlation_search_m);
    ++state.counters.registrations;
    // Beyond paper 002: the heading against the global map (correlation_heading_step_rad).
    // The peak score of the local map turned by -step, 0, +step; the parabola through them
    // places the best turn, a measurement of the heading error weighed like the shift.
    const double step = params_.correlation_heading_step_rad;
    if (step > 0 && reg.local_cells >= params_.correlation_min_cells) {
      const double s_minus =
          occupancy::CorrelateMaps(local_map(-step), state.grid, params_.correlation_search_m)
              .score;
      const double s_plus =
          occupancy::CorrelateMaps(local_map(step), state.grid, params_.correlation_search_m).score;
      const double curvature = 2.0 * reg.score - s_minus - s_plus;
      // A flat score (a corridor seen along its walls, a single wall) fixes no heading.
      if (reg.score > 0 && curvature / reg.score >= params_.correlation_min_sharpness) {
        const double measured =
            std::clamp(0.5 * step * (s_plus - s_minus) / curvature, -step, step);
        const double p = state.filter.heading_variance;
        const double r =
            params_.correlation_heading_sigma_rad * params_.correlation_heading_sigma_rad;
        const double gain = p / (p + r);
        state.filter.heading_variance = (1.0 - gain) * p;
        const double turn = gain * measured;
        state.poses.ApplyRotation(turn, stop_xy, group.first_record);
        report->heading_turn_rad = turn;
        ++state.counters.heading_turns;
        // The turn is a share of one step (twelve passes of the rooms route: median 0.05 deg,
        // max 0.32 deg, under 3 cm at the grid's 5 m range): the local map is merged as built.
      }
    }
    const int border =
        static_cast<int>(std::ceil(params_.correlation_search_m / state.grid.resolution()));
    const bool on_border = std::abs(reg.dx_cells) >= border || std::abs(reg.dy_cells) >= border;
    if (reg.local_cells >= params_.correlation_min_cells && !on_border) {
      // Along each axis, the shift counts only if the peak is sharp there (a corridor leaves
      // the position along it free); whole-cell moves must also clearly beat no shift.
      const bool sharp_x = reg.sharpness_x >= params_.correlation_min_sharpness;
      const bool sharp_y = reg.sharpness_y >= params_.correlation_min_sharpness;
      const bool gain = reg.score > reg.zero_score * (1.0 + params_.correlation_min_gain);
      const bool take_x = sharp_x && (reg.dx_cells == 0 || gain);
      const bool take_y = sharp_y && (reg.dy_cells == 0 || gain);
      const Eigen::Vector2d measured(take_x ? reg.dx_m : 0.0, take_y ? reg.dy_m : 0.0);
      // Kalman update per axis that measured anything: how much of the shift to believe.
      // Without a drift model (odometry_drift_per_m 0) the whole measured shift is taken.
      const bool filtered = params_.odometry_drift_per_m > 0;
      const double sigma = params_.correlation_sigma_cells * state.grid.resolution();
      const double r = sigma * sigma;
      Eigen::Vector2d kalman_gain = Eigen::Vector2d::Zero();
      for (int a = 0; a < 2; ++a) {
        const double p = state.filter.variance[a];
        if (a == 0 ? take_x : take_y) kalman_gain[a] = filtered ? p / (p + r) : 1.0;
      }
      const Eigen::Vector2d shift = kalman_gain.cwiseProduct(measured);
      if (measured.norm() > params_.correlation_max_shift_m) {
        ++state.counters.shifts_refused;  // far more than odometry drifts between two stops
      } else if (shift.norm() >= params_.correlation_min_shift_m) {
        state.filter.variance =
            (Eigen::Vector2d::Ones() - kalman_gain).cwiseProduct(state.filter.variance);
        // The local map is merged shifted by the whole cells of what was applied.
        const double res = state.grid.resolution();
        sx =
            take_x ? (filtered ? static_cast<int>(std::lround(shift.x() / res)) : reg.dx_cells) : 0;
        sy =
            take_y ? (filtered ? static_cast<int>(std::lround(shift.y() / res)) : reg.dy_cells) : 0;
        report->shifted = true;
        report->shift_m = shift;
        state.poses.ApplyTranslation(shift, group.first_record);
        ++state.counters.shifts_applied;
      }
    } else if (on_border) {
      ++state.counters.shifts_refused;  // the peak is at the edge of the search: no peak at all
    }
  }
  state.grid.MergeWeighted(local, sx, sy);

  // A view of the perceptual map from every key frame of the stop.
  std::vector<Eigen::Vector2d> points;
  for (const auto& fp : group.frames) {
    points.insert(points.end(), fp.reference_points.begin(), fp.reference_points.end());
  }
  const auto added = state.perceptual.AddView(state.poses.latest().stamp_ns, points,
                                              state.poses.latest().T_world_base);
  if (added.skipped) {
    ++state.counters.views_without_objects;
    report->view_skipped = true;
  } else {
    ++state.counters.views;
    report->map_expanded = added.expanded;
  }
}

bool MobileMapper::standing_at_stop() const {
  return group_.open &&
         static_cast<int>(group_.frames.size()) >= std::max(2, MinKeyFramesForView());
}

PerceptualMapOnRead::PerceptualMapOnRead(perceptual_map::PerceptualMapper mapper, OnBuilt on_built)
    : mapper_(std::move(mapper)), on_built_(std::move(on_built)) {}

const perceptual_map::PerceptualMap& PerceptualMapOnRead::Get() const {
  std::call_once(built_, [this] {
    const auto t0 = std::chrono::steady_clock::now();
    map_ = mapper_->Map(true);
    mapper_.reset();  // its copy of the map is no longer needed
    if (on_built_) {
      on_built_(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
  });
  return map_;
}

const perceptual_map::PerceptualMap& MapsSnapshot::perceptual() const {
  static const perceptual_map::PerceptualMap kNone;
  return perceptual_on_read ? perceptual_on_read->Get() : kNone;
}

std::shared_ptr<const MapsSnapshot> MobileMapper::SnapshotWithOpenStop() const {
  if (!standing_at_stop()) return Snapshot();
  occupancy::LayeredGrid grid = grid_;  // copies: the maps themselves stay as they are
  perceptual_map::PerceptualMapper perceptual = perceptual_;
  localisation::PoseCorrector poses = poses_;
  MapperCounters counters = counters_;
  PositionFilter filter = filter_;
  KeyFrameReport ignored;
  MergeGroup(group_, {grid, perceptual, poses, counters, filter}, &ignored);
  auto s = std::make_shared<MapsSnapshot>();
  s->stamp_ns = last_stamp_ns_;
  s->includes_open_stop = true;
  s->perceptual_on_read =
      std::make_shared<const PerceptualMapOnRead>(std::move(perceptual), on_perceptual_map_built_);
  s->grid = std::move(grid);
  s->poses = std::move(poses).TakeRecords();
  s->counters = counters_;  // what happened, not what the provisional merge would count
  return s;
}

std::shared_ptr<const MapsSnapshot> MobileMapper::Snapshot() const {
  auto s = std::make_shared<MapsSnapshot>();
  s->stamp_ns = last_stamp_ns_;
  if (!published_perceptual_ || published_perceptual_revision_ != perceptual_.revision()) {
    published_perceptual_ =
        std::make_shared<const PerceptualMapOnRead>(perceptual_, on_perceptual_map_built_);
    published_perceptual_revision_ = perceptual_.revision();
  }
  s->perceptual_on_read = published_perceptual_;
  s->grid = grid_;  // shares the cells until the mapper changes them (copy on write)
  s->poses = poses_.records();
  s->counters = counters_;
  s->resumed_unconfirmed = restore_unconfirmed_;
  return s;
}

}  // namespace epmap::mobile_mapping
