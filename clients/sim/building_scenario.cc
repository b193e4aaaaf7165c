// Scenario `building`: a differential-drive robot with a stereo camera on a pan unit
// (urdf/pan_robot.urdf) drives about 60 m through the floor of building_world.h, stopping
// every metre or 45 degrees of turn to look around by panning (papers 002 and 003). Its wheel
// odometry drifts: slightly unequal wheel radii and a wheelbase error plus noise bring the
// heading error to about 20 degrees over the run, as paper 002 reports for its real robot.
// With --walker a person walks along the first corridor (building_world.h, WalkerPose).

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "clients/sim/building_world.h"
#include "clients/sim/scenario_factories.h"
#include "clients/sim/stereo_shot.h"
#include "clients/sim/urdf_model.h"
#include "perception/kinematics/urdf_chain.h"

namespace epmap::sim {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
constexpr double kRateHz = 10.0;
constexpr int kDefaultWidth = 320, kDefaultHeight = 240;
constexpr double kFocalAt320 = 251.48735;  // paper 003, Table 1 (BumbleBee, 320x240)
constexpr double kBaselineM = 0.12;        // pan_robot.urdf: cameras at y = +-6 cm

// Motion: 0.5 m/s straight, 45 deg/s turning in place, a look-around every metre or 45 deg.
constexpr double kStepM = 0.05;              // per frame while driving
constexpr double kTurnStepRad = 4.5 * kDeg;  // per frame while turning
constexpr double kStopEveryM = 1.0;
constexpr double kStopEveryRad = 45 * kDeg;
// Pan angles of the frames taken at a stop (the pan moves 30 degrees between frames).
constexpr double kLookAround[] = {-30, -60, -30, 0, 30, 60, 30};

// Wheel odometry (Pioneer-like): nominal wheelbase 0.33 m. Truth: right wheel 0.09% larger,
// left 0.09% smaller than the nominal radius, wheelbase 0.8% wider; plus noise on each wheel's
// travel of 1 mm per sqrt(metre) (scaled by --encoder-noise-scale).
constexpr double kWheelbaseM = 0.33;
constexpr double kRightScale = 1.0009, kLeftScale = 0.9991, kTrueWheelbaseScale = 1.008;
constexpr double kWheelNoise = 0.001;
// Pan encoder: Gaussian noise then 0.01 degree steps.
constexpr double kPanNoiseDeg = 0.02, kPanStepDeg = 0.01;

double Wrap(double a) {
  return std::atan2(std::sin(a), std::cos(a));
}

struct State {
  double x = 0, y = 0, theta = 0;  // base in the floor frame
  double pan = 0;
  bool at_stop = false;
};

Eigen::Isometry3d Planar(double x, double y, double theta) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0);
  T.linear() = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

std::vector<State> Timeline(const std::string& route_name, bool reverse, int passes) {
  std::vector<Eigen::Vector2d> route = BuildingRoute(route_name);
  if (reverse) std::reverse(route.begin(), route.end());
  // Each further pass drives the route back from where the last one ended.
  const std::vector<Eigen::Vector2d> one_pass = route;
  for (int p = 1; p < passes; ++p) {
    if (p % 2) {
      route.insert(route.end(), one_pass.rbegin() + 1, one_pass.rend());
    } else {
      route.insert(route.end(), one_pass.begin() + 1, one_pass.end());
    }
  }
  std::vector<State> states;
  State s;
  s.x = route[0].x();
  s.y = route[0].y();
  s.theta = std::atan2(route[1].y() - route[0].y(), route[1].x() - route[0].x());
  const auto look_around = [&] {
    for (double pan : kLookAround) {
      State k = s;
      k.pan = pan * kDeg;
      k.at_stop = true;
      states.push_back(k);
    }
  };
  look_around();  // the run starts by looking around (paper 002)
  double since_stop_m = 0, since_stop_rad = 0;
  for (size_t i = 1; i < route.size(); ++i) {
    const Eigen::Vector2d leg = route[i] - Eigen::Vector2d(s.x, s.y);
    const double heading = std::atan2(leg.y(), leg.x());
    const double turn = Wrap(heading - s.theta);
    const int turn_steps = static_cast<int>(std::ceil(std::abs(turn) / kTurnStepRad - 1e-9));
    for (int k = 0; k < turn_steps; ++k) {
      s.theta = Wrap(s.theta + turn / turn_steps);
      states.push_back(s);
      since_stop_rad += std::abs(turn / turn_steps);
      if (since_stop_rad >= kStopEveryRad - 1e-9) {
        look_around();
        since_stop_rad = since_stop_m = 0;
      }
    }
    s.theta = heading;
    const double length = leg.norm();
    const int steps = static_cast<int>(std::ceil(length / kStepM - 1e-9));
    const Eigen::Vector2d start(s.x, s.y);
    for (int k = 1; k <= steps; ++k) {
      const Eigen::Vector2d p = start + leg * (static_cast<double>(k) / steps);
      s.x = p.x();
      s.y = p.y();
      states.push_back(s);
      since_stop_m += length / steps;
      if (since_stop_m >= kStopEveryM - 1e-9) {
        look_around();
        since_stop_rad = since_stop_m = 0;
      }
    }
  }
  if (!states.back().at_stop) look_around();
  return states;
}

std::string TruePanRobotUrdf() {
  return PerturbJointOrigin(PanRobotUrdf(), "pan", {0.0003, -0.0004, 0.0002},
                            {0.0004, -0.0005, 0.0003});
}

class BuildingScenario final : public Scenario {
 public:
  explicit BuildingScenario(const ScenarioOptions& options)
      : Scenario(options),
        world_(BuildBuilding(options.seed)),
        states_(Timeline(options.route, options.reverse, options.passes)),
        true_urdf_(options.noise ? TruePanRobotUrdf() : std::string(PanRobotUrdf())),
        nominal_chain_(kinematics::UrdfChain::FromString(PanRobotUrdf())),
        true_chain_(kinematics::UrdfChain::FromString(true_urdf_)) {
    const int route_frames = static_cast<int>(states_.size());
    if (options.first_frame >= route_frames) {
      throw std::invalid_argument("the building route has " + std::to_string(route_frames) +
                                  " frames; --first-frame " + std::to_string(options.first_frame) +
                                  " is past its end");
    }
    // The run starts part-way along the route: its odometry starts there.
    states_.erase(states_.begin(), states_.begin() + options.first_frame);
    const int natural = static_cast<int>(states_.size());
    if (options.frames > natural) {
      throw std::invalid_argument("the building route has " + std::to_string(natural) +
                                  " frames from frame " + std::to_string(options.first_frame) +
                                  "; --frames " + std::to_string(options.frames) + " is more");
    }
    frames_ = options.frames > 0 ? options.frames : natural;
    camera_.width = options.width > 0 ? options.width : kDefaultWidth;
    camera_.height = options.height > 0 ? options.height : kDefaultHeight;
    camera_.fx = camera_.fy = kFocalAt320 * camera_.width / 320.0;
    camera_.cx = (camera_.width - 1) / 2.0;
    camera_.cy = (camera_.height - 1) / 2.0;
    // The world frame is the forward run's start pose (also for --reverse, so that both runs
    // share one map).
    const auto route = BuildingRoute(options.route);
    T_world_floor_ = Planar(route[0].x(), route[0].y(),
                            std::atan2(route[1].y() - route[0].y(), route[1].x() - route[0].x()))
                         .inverse();
    IntegrateOdometry();
    flicker_ = SmoothSignal(Rng(options.seed, Stream::kFlicker, 0), 1.0, 0.3, 2.0);
  }

  int frame_count() const override { return frames_; }
  double rate_hz() const override { return kRateHz; }
  bool rectified() const override { return true; }
  bool has_odometry() const override { return true; }
  bool has_moving_objects() const override { return options().walker; }
  dataset::CameraSensor cam0() const override { return Sensor(nominal_chain_.Cam0Pose({0.0})); }
  dataset::CameraSensor cam1() const override { return Sensor(nominal_chain_.Cam1Pose({0.0})); }
  std::string urdf() const override { return PanRobotUrdf(); }
  std::string true_urdf() const override { return true_urdf_; }
  std::vector<std::string> joint_names() const override { return {"pan"}; }
  int num_disparities() const override {
    // The camera keeps at least ~0.4 m from what it sees.
    return 16 * static_cast<int>(std::ceil(camera_.fx * kBaselineM / 0.4 / 16));
  }
  // At the stops (where the maps are built) unless asked for every frame: 504 of 1849 frames.
  bool RecordsDisparity(const SimFrame& f) const override {
    return f.at_stop || options().disparity_every_frame;
  }

  std::vector<dataset::WallSegment> Walls() const override { return ToWorld(world_.wall_faces); }
  std::vector<dataset::WallSegment> Furniture() const override {
    return ToWorld(world_.furniture_faces);
  }

  SimFrame RenderFrame(int index, bool ground_truth) const override {
    CheckIndex(index);
    const State& s = states_[static_cast<size_t>(index)];
    SimFrame f;
    f.index = index;
    f.stamp_ns = StampNs(index);
    f.at_stop = s.at_stop;
    f.gt_joints = {s.pan};
    f.joints = {PanReading(s.pan, index)};
    const Eigen::Isometry3d T_floor_base = Planar(s.x, s.y, s.theta);
    const Eigen::Isometry3d T_world_base = T_world_floor_ * T_floor_base;
    const double yaw = std::atan2(T_world_base.linear()(1, 0), T_world_base.linear()(0, 0));
    f.gt_base = dataset::PlanarPose{f.stamp_ns, T_world_base.translation().x(),
                                    T_world_base.translation().y(), yaw};
    dataset::PlanarPose odom = odometry_[static_cast<size_t>(index)];
    odom.stamp_ns = f.stamp_ns;
    f.odometry = odom;

    StereoShot shot;
    shot.scene = &world_.scene;
    if (options().walker) {
      // The walker keeps the route's clock, wherever along it the run starts.
      const Eigen::Isometry3d T_floor_walker =
          WalkerPose((index + options().first_frame) / kRateHz);
      shot.moving = WalkerQuads(world_, T_floor_walker);
      f.gt_mover_centres = {T_world_floor_ * T_floor_walker *
                            Eigen::Vector3d(0, 0, kWalkerHeightM / 2)};
    }
    shot.camera = camera_;
    shot.T_world_cam0 = T_floor_base * true_chain_.Cam0Pose(f.gt_joints);
    shot.T_world_cam1 = T_floor_base * true_chain_.Cam1Pose(f.gt_joints);
    shot.gain = Gain(index);
    shot.sensor.noise_sigma = options().noise ? 2.0 : 0.0;
    shot.seed = options().seed;
    shot.index = index;
    shot.ground_truth = ground_truth;
    shot.rectified = true;
    shot.baseline = (shot.T_world_cam0.inverse() * shot.T_world_cam1).translation().x();
    shot.supersample = options().supersample > 0 ? options().supersample : 1;
    ShootStereo(shot, &f);
    // The renderer worked in the floor frame; report poses in the world frame.
    f.gt_T_world_cam0 = T_world_floor_ * f.gt_T_world_cam0;
    f.gt_T_world_cam1 = T_world_floor_ * f.gt_T_world_cam1;
    return f;
  }

  std::string Describe() const override {
    return std::string("building") +
           (options().route != "corridors" ? " route " + options().route : "") +
           (options().reverse ? " (reverse)" : "") +
           (options().passes > 1 ? ", " + std::to_string(options().passes) + " passes" : "") +
           (options().walker ? " with a walker" : "") + ": " + std::to_string(frames_) +
           " stereo frames " +
           (options().first_frame > 0 ? "from frame " + std::to_string(options().first_frame) + " "
                                      : std::string()) +
           std::to_string(camera_.width) + "x" + std::to_string(camera_.height) +
           " at 10 Hz, seed " + std::to_string(options().seed);
  }

 private:
  dataset::CameraSensor Sensor(const Eigen::Isometry3d& T_base_cam) const {
    return SensorDescription(camera_, T_base_cam, kRateHz);
  }

  std::vector<dataset::WallSegment> ToWorld(const std::vector<dataset::WallSegment>& in) const {
    std::vector<dataset::WallSegment> out;
    out.reserve(in.size());
    for (const auto& w : in) {
      const Eigen::Vector3d a = T_world_floor_ * Eigen::Vector3d(w.x1, w.y1, 0);
      const Eigen::Vector3d b = T_world_floor_ * Eigen::Vector3d(w.x2, w.y2, 0);
      out.push_back({a.x(), a.y(), b.x(), b.y()});
    }
    return out;
  }

  double PanReading(double pan, int index) const {
    if (!options().noise) return pan;
    Rng rng(options().seed, Stream::kEncoderNoise, static_cast<uint64_t>(index));
    const double step = kPanStepDeg * kDeg;
    const double noisy = pan + kPanNoiseDeg * kDeg * options().encoder_noise_scale * rng.Gaussian();
    return std::round(noisy / step) * step;
  }

  double Gain(int index) const {
    if (!options().noise) return 1.0;
    Rng rng(options().seed, Stream::kFlicker, static_cast<uint64_t>(index) + 1);
    return 1.0 +
           options().flicker_scale * (0.02 * flicker_(index / kRateHz) + 0.01 * rng.Uniform(-1, 1));
  }

  // Dead reckoning from simulated wheel travel, in the start frame of this run.
  void IntegrateOdometry() {
    const bool noisy = options().noise;
    const double right_scale = noisy ? kRightScale : 1.0, left_scale = noisy ? kLeftScale : 1.0;
    const double true_wheelbase = kWheelbaseM * (noisy ? kTrueWheelbaseScale : 1.0);
    const double sigma = noisy ? kWheelNoise * options().encoder_noise_scale : 0.0;
    double x = 0, y = 0, theta = 0;
    odometry_.push_back({0, 0, 0, 0});
    for (size_t k = 1; k < states_.size(); ++k) {
      const State& a = states_[k - 1];
      const State& b = states_[k];
      // True motion in the base frame: straight driving or turning in place.
      const double ds = std::hypot(b.x - a.x, b.y - a.y);
      const double dtheta = Wrap(b.theta - a.theta);
      const double true_right = ds + dtheta * true_wheelbase / 2;
      const double true_left = ds - dtheta * true_wheelbase / 2;
      Rng rng(options().seed, Stream::kOdometryNoise, k);
      const double right =
          true_right * right_scale + sigma * std::sqrt(std::abs(true_right)) * rng.Gaussian();
      const double left =
          true_left * left_scale + sigma * std::sqrt(std::abs(true_left)) * rng.Gaussian();
      // The encoders count the travel of wheels (1 + E_s) larger than they really are.
      const double counted = 1.0 / (1.0 + options().odometry_scale_error);
      const double d = counted * (right + left) / 2, turn = counted * (right - left) / kWheelbaseM;
      x += d * std::cos(theta + turn / 2);
      y += d * std::sin(theta + turn / 2);
      theta = Wrap(theta + turn);
      odometry_.push_back({0, x, y, theta});
    }
  }

  BuildingWorld world_;
  std::vector<State> states_;
  std::vector<dataset::PlanarPose> odometry_;
  int frames_ = 0;
  PinholeCamera camera_;
  Eigen::Isometry3d T_world_floor_ = Eigen::Isometry3d::Identity();
  std::string true_urdf_;
  kinematics::UrdfChain nominal_chain_;
  kinematics::UrdfChain true_chain_;
  SmoothSignal flicker_;
};

}  // namespace

std::unique_ptr<Scenario> MakeBuildingScenario(const ScenarioOptions& options) {
  return std::make_unique<BuildingScenario>(options);
}

}  // namespace epmap::sim
