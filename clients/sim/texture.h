#pragma once
// Mip-mapped, wrapping surface textures. Band-limited content (see texture_library.h) plus a
// Gaussian pyramid and trilinear filtering by the pixel footprint keep the rendered images
// free of aliasing from the nearest surface to the farthest.

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace epmap::sim {

class Texture {
 public:
  // level0: CV_8UC1 (grey) or CV_8UC3 (BGR) whose sides are powers of two (>= 4). Coordinates
  // wrap, so a texture tiles a surface seamlessly when its content is periodic. Colour levels
  // are stored as BGRx (4 bytes per texel) so that a texel is one aligned 32-bit load.
  explicit Texture(const cv::Mat& level0);

  int channels() const { return channels_; }
  int levels() const { return static_cast<int>(levels_.size()); }
  // Level i as stored: CV_8UC1 or CV_8UC4 (BGRx).
  const cv::Mat& level(int i) const { return levels_[static_cast<size_t>(i)]; }
  int width() const { return levels_[0].cols; }
  int height() const { return levels_[0].rows; }

  // Trilinear sample at level-0 texel coordinates (s, t) (texel centres at integers), for a
  // pixel whose footprint covers sqrt(footprint_sq) level-0 texels. Writes channels() floats
  // (0..255) to out, which must have room for 4.
  void Sample(double s, double t, double footprint_sq, float* out) const {
    if (footprint_sq <= 1.0) {  // magnified: the finest level only
      Bilinear(0, s, t, out);
      return;
    }
    // Level of detail as GPUs pick it, log2 of the footprint, blended between two levels.
    const double lod = 0.5 * FastLog2(footprint_sq);
    const int max_level = levels() - 1;
    if (lod >= max_level) {
      Bilinear(max_level, s, t, out);
      return;
    }
    // Blend only in the middle half between two levels ("brilinear", as GPUs do to save the
    // second fetch): the transition stays continuous, at half the cost of full trilinear.
    const int l0 = static_cast<int>(lod);
    const double f = (lod - l0 - 0.25) * 2.0;
    if (f <= 0.0) {
      Bilinear(l0, s, t, out);
    } else if (f >= 1.0) {
      Bilinear(l0 + 1, s, t, out);
    } else {
      float upper[4] = {0, 0, 0, 0};
      Bilinear(l0, s, t, out);
      Bilinear(l0 + 1, s, t, upper);
      const float w = static_cast<float>(f);
      for (int k = 0; k < 4; ++k) out[k] += w * (upper[k] - out[k]);
    }
  }

  // log2(x) for x >= 1, piecewise linear between powers of two (exact at them, within 0.09
  // elsewhere): enough to blend mip levels, and far cheaper than std::log2.
  static double FastLog2(double x) {
    const uint64_t bits = std::bit_cast<uint64_t>(x);
    const int exponent = static_cast<int>((bits >> 52) & 0x7FF) - 1023;
    const double mantissa =
        std::bit_cast<double>((bits & 0x000FFFFFFFFFFFFFull) | 0x3FF0000000000000ull);
    return exponent + (mantissa - 1.0);
  }

 private:
  // floor() for texture coordinates, without the libm call.
  static int64_t Floor(double v) {
    const int64_t i = static_cast<int64_t>(v);
    return i - (static_cast<double>(i) > v);
  }

  void Bilinear(int lvl, double s, double t, float* out) const {
    const Level& L = data_[static_cast<size_t>(lvl)];
    const double ls = s * L.scale, lt = t * L.scale;
    const int64_t fs = Floor(ls), ft = Floor(lt);
    const float ws = static_cast<float>(ls - static_cast<double>(fs));
    const float wt = static_cast<float>(lt - static_cast<double>(ft));
    const int x0 = static_cast<int>(fs & L.wmask), y0 = static_cast<int>(ft & L.hmask);
    const int x1 = (x0 + 1) & L.wmask, y1 = (y0 + 1) & L.hmask;
    const uint8_t* r0 = L.data + static_cast<size_t>(y0) * L.step;
    const uint8_t* r1 = L.data + static_cast<size_t>(y1) * L.step;
    const float w00 = (1 - ws) * (1 - wt), w01 = ws * (1 - wt), w10 = (1 - ws) * wt;
    const float w11 = ws * wt;
    if (channels_ == 1) {
      out[0] = w00 * r0[x0] + w01 * r0[x1] + w10 * r1[x0] + w11 * r1[x1];
      return;
    }
#if defined(__SSE2__)
    const __m128i zero = _mm_setzero_si128();
    const auto texel = [&](const uint8_t* p) {
      int32_t v;
      std::memcpy(&v, p, 4);
      const __m128i b = _mm_unpacklo_epi8(_mm_cvtsi32_si128(v), zero);
      return _mm_cvtepi32_ps(_mm_unpacklo_epi16(b, zero));
    };
    __m128 acc = _mm_mul_ps(texel(r0 + 4 * x0), _mm_set1_ps(w00));
    acc = _mm_add_ps(acc, _mm_mul_ps(texel(r0 + 4 * x1), _mm_set1_ps(w01)));
    acc = _mm_add_ps(acc, _mm_mul_ps(texel(r1 + 4 * x0), _mm_set1_ps(w10)));
    acc = _mm_add_ps(acc, _mm_mul_ps(texel(r1 + 4 * x1), _mm_set1_ps(w11)));
    _mm_storeu_ps(out, acc);
#else
    for (int k = 0; k < 4; ++k) {
      out[k] =
          w00 * r0[4 * x0 + k] + w01 * r0[4 * x1 + k] + w10 * r1[4 * x0 + k] + w11 * r1[4 * x1 + k];
    }
#endif
  }

  // Raw views of the levels for the sampler's inner loop.
  struct Level {
    const uint8_t* data;
    size_t step;
    int wmask, hmask;
    double scale;  // 2^-level: level-0 texel coordinates to this level's
  };

  int channels_ = 0;
  std::vector<cv::Mat> levels_;
  std::vector<Level> data_;
};

}  // namespace epmap::sim
