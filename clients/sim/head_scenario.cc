// Scenarios `head` and `vergence`: the iCub-like head of urdf/icub_head.urdf in the furnished
// room of head_world.h (paper 000, Sec. V: random head motion, an independently moving object;
// paper 001, Sec. III-A: verging eyes whose stereo extrinsics must be recovered from images).

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "clients/sim/head_world.h"
#include "clients/sim/scenario_factories.h"
#include "clients/sim/stereo_shot.h"
#include "clients/sim/urdf_model.h"
#include "perception/kinematics/urdf_chain.h"

namespace epmap::sim {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kRateHz = 30.0;
constexpr int kDefaultFrames = 300;
constexpr int kDefaultWidth = 640, kDefaultHeight = 480;
constexpr double kHorizontalFovDeg = 60.0;
constexpr double kBaselineM = 0.068;  // icub_head.urdf: eyes at y = +-34 mm

// Encoders: Gaussian noise (scaled by --encoder-noise-scale), then 0.01 degree steps.
constexpr double kEncoderNoiseDeg = 0.02;
constexpr double kEncoderStepDeg = 0.01;
// vergence: the eye encoders' zero differs from the truth (reading = true + bias).
constexpr double kLeftPanBiasDeg = 0.40, kRightPanBiasDeg = -0.35, kTiltBiasDeg = 0.15;
constexpr double kNominalVergenceDeg = 4.5;  // fixation at ~0.87 m

// Joint order of icub_head.urdf (and of joints0/).
enum Joint { kNeckPitch, kNeckRoll, kNeckYaw, kEyesTilt, kLeftPan, kRightPan, kJoints };
const std::vector<std::string> kJointNames = {"neck_pitch", "neck_roll",    "neck_yaw",
                                              "eyes_tilt",  "left_eye_pan", "right_eye_pan"};

// The true head differs from the shipped URDF by sub-millimetre, few-hundredths-of-a-degree
// offsets at the neck's yaw joint and the eyes' tilt joint, both upstream of the eyes so that
// the true rig stays rectified in `head`.
std::string TrueHeadUrdf() {
  std::string urdf = IcubHeadUrdf();
  urdf = PerturbJointOrigin(urdf, "neck_yaw", {-0.0002, 0.0003, 0.0004}, {0.0004, -0.0003, 0.0005});
  urdf =
      PerturbJointOrigin(urdf, "eyes_tilt", {0.0004, -0.0002, -0.0003}, {-0.0005, 0.0006, 0.0003});
  return urdf;
}

class HeadScenario final : public Scenario {
 public:
  HeadScenario(const ScenarioOptions& options, bool vergence)
      : Scenario(options),
        vergence_(vergence),
        frames_(options.frames > 0 ? options.frames : kDefaultFrames),
        room_(BuildHeadRoom(options.seed)),
        true_urdf_(options.noise ? TrueHeadUrdf() : std::string(IcubHeadUrdf())),
        nominal_chain_(kinematics::UrdfChain::FromString(IcubHeadUrdf())),
        true_chain_(kinematics::UrdfChain::FromString(true_urdf_)) {
    nominal_chain_.BindJointOrder(kJointNames);
    true_chain_.BindJointOrder(kJointNames);
    camera_.width = options.width > 0 ? options.width : kDefaultWidth;
    camera_.height = options.height > 0 ? options.height : kDefaultHeight;
    camera_.fx = camera_.fy = camera_.width / 2.0 / std::tan(kHorizontalFovDeg / 2 * kDeg);
    camera_.cx = (camera_.width - 1) / 2.0;
    camera_.cy = (camera_.height - 1) / 2.0;

    const uint64_t seed = options.seed;
    // Neck: smooth random motion. head: +-18 deg yaw, +-8 pitch around 13 deg down, +-4 roll;
    // at most ~1.5 deg per frame. vergence: the neck moves half as much, the eyes move.
    const double k = vergence ? 0.5 : 1.0;
    pitch_ = SmoothSignal(Rng(seed, Stream::kHeadMotion, 0), k * 8 * kDeg, 0.05, 0.30);
    roll_ = SmoothSignal(Rng(seed, Stream::kHeadMotion, 1), k * 4 * kDeg, 0.05, 0.25);
    yaw_ = SmoothSignal(Rng(seed, Stream::kHeadMotion, 2), k * 18 * kDeg, 0.04, 0.25);
    tilt_ = SmoothSignal(Rng(seed, Stream::kEyeMotion, 0), 5 * kDeg, 0.05, 0.35);
    version_ = SmoothSignal(Rng(seed, Stream::kEyeMotion, 1), 6 * kDeg, 0.05, 0.35);
    vergence_signal_ = SmoothSignal(Rng(seed, Stream::kEyeMotion, 2), 2.5 * kDeg, 0.05, 0.30);
    flicker_ = SmoothSignal(Rng(seed, Stream::kFlicker, 0), 1.0, 0.3, 2.0);
  }

  int frame_count() const override { return frames_; }
  double rate_hz() const override { return kRateHz; }
  bool rectified() const override { return !vergence_; }
  // T_BS: head with every joint at zero; in `vergence` the eyes at the nominal 4.5 degree
  // vergence, so that the sensor files describe a verging (unrectified) rig.
  dataset::CameraSensor cam0() const override {
    return Sensor(nominal_chain_.Cam0Pose(NominalJoints()));
  }
  dataset::CameraSensor cam1() const override {
    return Sensor(nominal_chain_.Cam1Pose(NominalJoints()));
  }
  std::string urdf() const override { return IcubHeadUrdf(); }
  std::string true_urdf() const override { return true_urdf_; }
  std::vector<std::string> joint_names() const override { return kJointNames; }
  bool has_moving_objects() const override { return !vergence_; }
  int num_disparities() const override {
    if (vergence_) return 0;
    // Nothing comes nearer than ~0.38 m to the cameras.
    return 16 * static_cast<int>(std::ceil(camera_.fx * kBaselineM / 0.38 / 16));
  }

  SimFrame RenderFrame(int index, bool ground_truth) const override {
    CheckIndex(index);
    const double t = index / kRateHz;
    SimFrame f;
    f.index = index;
    f.stamp_ns = StampNs(index);
    f.gt_joints = TrueJoints(t);
    f.joints = Encoders(f.gt_joints, index);

    StereoShot shot;
    shot.scene = &room_.scene;
    if (!vergence_) {
      if (const auto toy = ToyPose(options().seed, t)) {
        shot.moving = ToyQuads(room_, *toy);
        f.gt_mover_centres = {toy->translation()};
      }
    }
    shot.camera = camera_;
    // The world frame is base_link: the kinematic chain gives the camera poses directly.
    shot.T_world_cam0 = true_chain_.Cam0Pose(f.gt_joints);
    shot.T_world_cam1 = true_chain_.Cam1Pose(f.gt_joints);
    shot.gain = Gain(t, index);
    shot.sensor.noise_sigma = options().noise ? 2.0 : 0.0;
    shot.seed = options().seed;
    shot.index = index;
    shot.ground_truth = ground_truth;
    shot.rectified = !vergence_;
    // The true rig is rectified by construction; take its baseline from the chain itself.
    shot.baseline = (shot.T_world_cam0.inverse() * shot.T_world_cam1).translation().x();
    shot.supersample = options().supersample > 0 ? options().supersample : 1;
    ShootStereo(shot, &f);
    return f;
  }

  std::string Describe() const override {
    return std::string(vergence_ ? "vergence" : "head") + ": " + std::to_string(frames_) +
           " stereo frames " + std::to_string(camera_.width) + "x" +
           std::to_string(camera_.height) + " at 30 Hz, seed " + std::to_string(options().seed);
  }

 private:
  std::vector<double> NominalJoints() const {
    std::vector<double> q(kJoints, 0.0);
    if (vergence_) {
      q[kLeftPan] = kNominalVergenceDeg / 2 * kDeg;
      q[kRightPan] = -kNominalVergenceDeg / 2 * kDeg;
    }
    return q;
  }

  dataset::CameraSensor Sensor(const Eigen::Isometry3d& T_base_cam) const {
    return SensorDescription(camera_, T_base_cam, kRateHz);
  }

  std::vector<double> TrueJoints(double t) const {
    std::vector<double> q(kJoints, 0.0);
    if (!vergence_) {
      q[kNeckPitch] = -13 * kDeg + pitch_(t);
      q[kNeckRoll] = roll_(t);
      q[kNeckYaw] = yaw_(t);
      // Eyes parallel and still: the pair stays rectified.
    } else {
      q[kNeckPitch] = -9 * kDeg + pitch_(t);
      q[kNeckRoll] = roll_(t);
      q[kNeckYaw] = yaw_(t);
      q[kEyesTilt] = -4 * kDeg + tilt_(t);
      const double version = version_(t);
      const double vergence = kNominalVergenceDeg * kDeg + vergence_signal_(t);  // 2 to 7 deg
      q[kLeftPan] = version + vergence / 2;
      q[kRightPan] = version - vergence / 2;
    }
    return q;
  }

  std::vector<double> Encoders(const std::vector<double>& q, int index) const {
    if (!options().noise) return q;
    std::vector<double> r = q;
    if (vergence_) {
      r[kEyesTilt] += kTiltBiasDeg * kDeg;
      r[kLeftPan] += kLeftPanBiasDeg * kDeg;
      r[kRightPan] += kRightPanBiasDeg * kDeg;
    }
    Rng rng(options().seed, Stream::kEncoderNoise, static_cast<uint64_t>(index));
    const double sigma = kEncoderNoiseDeg * kDeg * options().encoder_noise_scale;
    const double step = kEncoderStepDeg * kDeg;
    for (double& v : r) v = std::round((v + sigma * rng.Gaussian()) / step) * step;
    return r;
  }

  // Global illumination gain: a smooth flicker of up to 2% plus up to 1% per-frame jitter.
  double Gain(double t, int index) const {
    if (!options().noise) return 1.0;
    Rng rng(options().seed, Stream::kFlicker, static_cast<uint64_t>(index) + 1);
    return 1.0 + options().flicker_scale * (0.02 * flicker_(t) + 0.01 * rng.Uniform(-1, 1));
  }

  bool vergence_;
  int frames_;
  PinholeCamera camera_;
  HeadRoom room_;
  std::string true_urdf_;
  kinematics::UrdfChain nominal_chain_;
  kinematics::UrdfChain true_chain_;
  SmoothSignal pitch_, roll_, yaw_, tilt_, version_, vergence_signal_, flicker_;
};

}  // namespace

std::unique_ptr<Scenario> MakeHeadScenario(const ScenarioOptions& options, bool vergence) {
  return std::make_unique<HeadScenario>(options, vergence);
}

}  // namespace epmap::sim
