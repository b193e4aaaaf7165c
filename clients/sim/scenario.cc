#include "clients/sim/scenario.h"

#include <cmath>
#include <stdexcept>

#include "clients/sim/building_world.h"
#include "clients/sim/scenario_factories.h"

namespace epmap::sim {

int64_t Scenario::StampNs(int index) const {
  return options_.start_stamp_ns + std::llround(index * 1e9 / rate_hz());
}

void Scenario::CheckIndex(int index) const {
  if (frame_count() == 0) {
    throw std::logic_error("scenario '" + options_.name + "' has no images to render");
  }
  if (index < 0 || index >= frame_count()) {
    throw std::out_of_range("frame " + std::to_string(index) + " is outside [0, " +
                            std::to_string(frame_count()) + ") of scenario '" + options_.name +
                            "'");
  }
}

std::string Scenario::Describe() const {
  return options_.name + ": " + std::to_string(frame_count()) + " frames, seed " +
         std::to_string(options_.seed);
}

std::vector<std::string> ScenarioNames() {
  return {"head", "vergence", "building", "eye-hand"};
}

std::unique_ptr<Scenario> MakeScenario(const ScenarioOptions& options) {
  std::string known;
  for (const auto& n : ScenarioNames()) known += (known.empty() ? "" : ", ") + n;
  const std::string& name = options.name;
  bool found = false;
  for (const auto& n : ScenarioNames()) found |= n == name;
  if (!found) {
    throw std::invalid_argument("unknown scenario '" + name + "' (known: " + known + ")");
  }
  if (options.width < 0 || options.height < 0 || (options.width == 0) != (options.height == 0)) {
    throw std::invalid_argument("image size " + std::to_string(options.width) + "x" +
                                std::to_string(options.height) +
                                " is not valid: width and height must both be positive");
  }
  if (options.width > 8192 || options.height > 8192) {
    throw std::invalid_argument("image size " + std::to_string(options.width) + "x" +
                                std::to_string(options.height) + " is too large (max 8192)");
  }
  if (options.frames < 0) {
    throw std::invalid_argument("frame count " + std::to_string(options.frames) +
                                " is negative (0 = the scenario's default)");
  }
  if (!(options.encoder_noise_scale >= 0) || !(options.flicker_scale >= 0) ||
      !std::isfinite(options.encoder_noise_scale) || !std::isfinite(options.flicker_scale)) {
    throw std::invalid_argument("noise and flicker scales must be finite and >= 0");
  }
  if (!(std::abs(options.odometry_scale_error) < 0.2)) {
    throw std::invalid_argument("odometry scale error must be finite and within +-0.2");
  }
  if (options.odometry_scale_error != 0 && name != "building") {
    throw std::invalid_argument("--odometry-scale-error applies to the building scenario only");
  }
  if (options.reverse && name != "building") {
    throw std::invalid_argument("--reverse applies to the building scenario only");
  }
  if (options.passes < 1 || options.passes > 100) {
    throw std::invalid_argument("--passes must be within 1..100, got " +
                                std::to_string(options.passes));
  }
  if (options.passes != 1 && name != "building") {
    throw std::invalid_argument("--passes applies to the building scenario only");
  }
  if (options.route != "corridors" && name != "building") {
    throw std::invalid_argument("--route applies to the building scenario only");
  }
  if (name == "building") BuildingRoute(options.route);  // throws for an unknown route
  if (options.disparity_every_frame && name != "building") {
    throw std::invalid_argument(
        "--disparity-every-frame applies to the building scenario only (the others write it "
        "for every frame)");
  }
  if (options.walker && name != "building") {
    throw std::invalid_argument("--walker applies to the building scenario only");
  }
  if (options.first_frame != 0 && name != "building") {
    throw std::invalid_argument("--first-frame applies to the building scenario only");
  }
  if (options.first_frame < 0) {
    throw std::invalid_argument("--first-frame " + std::to_string(options.first_frame) +
                                " is negative");
  }
  if (options.supersample < 0 || (options.supersample > 0 && options.supersample % 2 == 0)) {
    throw std::invalid_argument("--supersample " + std::to_string(options.supersample) +
                                " must be odd (1, 3, 5...: the middle sample is the pixel centre)");
  }
  if (options.supersample > 7) {
    throw std::invalid_argument("--supersample " + std::to_string(options.supersample) +
                                " is more than 7 (49 samples per pixel)");
  }
  if (name == "eye-hand" && (options.width > 0 || options.frames > 0 || options.supersample > 0)) {
    throw std::invalid_argument(
        "eye-hand has no images: --size, --frames and --supersample do not apply (20 "
        "ellipsoidal paths of 100 samples)");
  }
  if (name == "head") return MakeHeadScenario(options, false);
  if (name == "vergence") return MakeHeadScenario(options, true);
  if (name == "building") return MakeBuildingScenario(options);
  return MakeEyeHandScenario(options);
}

std::pair<int, int> ParseImageSize(const std::string& text) {
  const auto x = text.find_first_of("xX");
  const auto fail = [&]() -> std::pair<int, int> {
    throw std::invalid_argument("image size '" + text +
                                "' is not valid: expected WxH with both positive, e.g. 320x240");
  };
  if (x == std::string::npos || x == 0 || x + 1 >= text.size()) return fail();
  size_t used_w = 0, used_h = 0;
  long w = 0, h = 0;
  try {
    w = std::stol(text.substr(0, x), &used_w);
    h = std::stol(text.substr(x + 1), &used_h);
  } catch (const std::exception&) {
    return fail();
  }
  if (used_w != x || used_h != text.size() - x - 1 || w <= 0 || h <= 0 || w > 8192 || h > 8192) {
    return fail();
  }
  return {static_cast<int>(w), static_cast<int>(h)};
}

}  // namespace epmap::sim
