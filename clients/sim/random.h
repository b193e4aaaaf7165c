#pragma once
// Deterministic randomness for the synthetic worlds. Every random quantity is a pure function
// of (seed, stream, index): a frame can be rendered alone, in any order, on any thread, and the
// same seed always gives the same bytes. The generator is SplitMix64 (public-domain constants),
// chosen for its speed and because its output does not depend on the standard library.

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

namespace epmap::sim {

// Named streams keep unrelated random quantities independent of each other.
enum class Stream : uint64_t {
  kTextures = 1,
  kHeadMotion,
  kEyeMotion,
  kObjectMotion,
  kEncoderNoise,
  kImageNoise,
  kFlicker,
  kOdometryNoise,
  kEyeHand,
  kWorldLayout,
};

inline uint64_t Mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

class Rng {
 public:
  Rng(uint64_t seed, Stream stream, uint64_t index = 0)
      : state_(Mix64(seed ^ Mix64(static_cast<uint64_t>(stream) * 0xD1B54A32D192ED03ull ^
                                  Mix64(index + 0x632BE59BD9B4E019ull)))) {}

  uint64_t Next() {
    state_ += 0x9E3779B97F4A7C15ull;
    uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  int UniformInt(int lo, int hi_inclusive) {
    return lo + static_cast<int>(Next() % static_cast<uint64_t>(hi_inclusive - lo + 1));
  }
  // Standard normal by Box-Muller (no cached second value: every call costs two uniforms, which
  // keeps the sequence a simple function of the call count).
  double Gaussian() {
    const double u1 = 1.0 - Uniform();  // (0, 1]
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  uint64_t state_;
};

// A smooth random signal: a sum of sinusoids with random frequencies in [f_min, f_max] Hz and
// random phases, scaled so that |value| <= amplitude at all times and the derivative is at
// most amplitude * 2 pi f_max. Deterministic for (seed, stream, index).
class SmoothSignal {
 public:
  SmoothSignal() = default;
  SmoothSignal(Rng rng, double amplitude, double f_min, double f_max, int components = 4) {
    double weight_sum = 0;
    for (int i = 0; i < components; ++i) {
      Component c;
      c.frequency = rng.Uniform(f_min, f_max);
      c.phase = rng.Uniform(0, 2 * std::numbers::pi);
      c.weight = rng.Uniform(0.5, 1.0);
      weight_sum += c.weight;
      components_.push_back(c);
    }
    for (auto& c : components_) c.weight *= amplitude / weight_sum;
  }
  double operator()(double t) const {
    double v = 0;
    for (const auto& c : components_) {
      v += c.weight * std::sin(2 * std::numbers::pi * c.frequency * t + c.phase);
    }
    return v;
  }

 private:
  struct Component {
    double frequency = 0, phase = 0, weight = 0;
  };
  std::vector<Component> components_;
};

}  // namespace epmap::sim
