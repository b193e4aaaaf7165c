#include "clients/sim/texture_library.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <string>

namespace epmap::sim::textures {

namespace {

cv::Vec3f Bgr(const cv::Scalar& s) {
  return {static_cast<float>(s[0]), static_cast<float>(s[1]), static_cast<float>(s[2])};
}

// colour + noise * contrast (+ a faint independent hue variation), saturated to 8 bits.
cv::Mat Tint(const cv::Mat& noise, const cv::Mat& hue_noise, const cv::Vec3f& colour,
             double contrast, double hue_contrast) {
  cv::Mat out(noise.size(), CV_8UC3);
  for (int y = 0; y < noise.rows; ++y) {
    const float* n = noise.ptr<float>(y);
    const float* h = hue_noise.ptr<float>(y);
    auto* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < noise.cols; ++x) {
      const float g = static_cast<float>(contrast) * n[x];
      const float hv = static_cast<float>(hue_contrast) * h[x];
      o[x] = cv::Vec3b(cv::saturate_cast<uint8_t>(colour[0] + g - hv),
                       cv::saturate_cast<uint8_t>(colour[1] + g),
                       cv::saturate_cast<uint8_t>(colour[2] + g + hv));
    }
  }
  return out;
}

// Draws at 2x with anti-aliasing, then averages down and softens: printed patterns with sharp
// but band-limited edges.
cv::Mat Downsample2x(const cv::Mat& big) {
  cv::Mat small, soft;
  cv::resize(big, small, cv::Size(big.cols / 2, big.rows / 2), 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(small, soft, cv::Size(0, 0), 0.6);
  return soft;
}

cv::Scalar RandomColour(Rng& rng, double lo, double hi) {
  return cv::Scalar(rng.Uniform(lo, hi), rng.Uniform(lo, hi), rng.Uniform(lo, hi));
}

std::string RandomWord(Rng& rng, int min_len, int max_len, bool capital) {
  std::string w;
  const int n = rng.UniformInt(min_len, max_len);
  for (int i = 0; i < n; ++i) {
    const char base = (capital && i == 0) ? 'A' : 'a';
    w.push_back(static_cast<char>(base + rng.UniformInt(0, 25)));
  }
  return w;
}

}  // namespace

cv::Mat BandLimitedNoise(int width, int height, const Spectrum& sp, Rng& rng) {
  cv::Mat spectrum(height, width, CV_32FC2, cv::Scalar(0, 0));
  const double taper_start = 0.75 * sp.cutoff;
  for (int v = 0; v < height; ++v) {
    const double fv = (v <= height / 2 ? v : v - height) / static_cast<double>(height);
    auto* row = spectrum.ptr<cv::Vec2f>(v);
    for (int u = 0; u < width; ++u) {
      const double fu = (u <= width / 2 ? u : u - width) / static_cast<double>(width);
      // Frequency in cycles per texel; stretching compresses the spectrum along x.
      const double r = std::hypot(fu * sp.stretch, fv);
      const double cycles = std::hypot(fu * width, fv * height);
      if (cycles < sp.min_cycles || r >= sp.cutoff) continue;
      double a = std::pow(r, -sp.beta);
      if (r > taper_start) {
        const double c =
            std::cos(0.5 * std::numbers::pi * (r - taper_start) / (sp.cutoff - taper_start));
        a *= c * c;
      }
      // Uniform components: the inverse DFT sums many of them, so the field is Gaussian anyway.
      row[u] = cv::Vec2f(static_cast<float>(a * (rng.Uniform() - 0.5)),
                         static_cast<float>(a * (rng.Uniform() - 0.5)));
    }
  }
  cv::Mat field;
  cv::dft(spectrum, field, cv::DFT_INVERSE | cv::DFT_SCALE);
  cv::Mat planes[2];
  cv::split(field, planes);
  cv::Scalar mean, stddev;
  cv::meanStdDev(planes[0], mean, stddev);
  cv::Mat out;
  planes[0].convertTo(out, CV_32F, 1.0 / std::max(stddev[0], 1e-12), -mean[0] / stddev[0]);
  return out;
}

cv::Mat Paint(Rng& rng, int size, const cv::Scalar& colour, double contrast) {
  // Roller texture: most energy at mid frequencies, a little large-scale unevenness.
  const cv::Mat n = BandLimitedNoise(size, size, {0.8, 2.0, 0.3, 1.0}, rng);
  const cv::Mat h = BandLimitedNoise(size, size, {1.5, 1.0, 0.1, 1.0}, rng);
  return Tint(n, h, Bgr(colour), contrast, 0.3 * contrast);
}

cv::Mat Wood(Rng& rng, int size, const cv::Scalar& light, const cv::Scalar& dark,
             bool grain_along_y) {
  const cv::Mat grain = BandLimitedNoise(size, size, {1.0, 1.0, 0.3, 6.0}, rng);
  const cv::Mat warp = BandLimitedNoise(size, size, {2.0, 1.0, 0.05, 3.0}, rng);
  const cv::Vec3f l = Bgr(light), d = Bgr(dark);
  const double rings = rng.UniformInt(6, 12);  // ring stripes per texture side (periodic)
  cv::Mat out(size, size, CV_8UC3);
  for (int y = 0; y < size; ++y) {
    const float* g = grain.ptr<float>(y);
    const float* w = warp.ptr<float>(y);
    auto* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < size; ++x) {
      const double phase = 2 * std::numbers::pi * (rings * y / size) + 1.2 * w[x];
      double m = 0.5 + 0.22 * std::sin(phase) + 0.2 * g[x];
      m = std::clamp(m, 0.0, 1.0);
      const cv::Vec3f c = l * static_cast<float>(1 - m) + d * static_cast<float>(m);
      o[x] = cv::Vec3b(cv::saturate_cast<uint8_t>(c[0]), cv::saturate_cast<uint8_t>(c[1]),
                       cv::saturate_cast<uint8_t>(c[2]));
    }
  }
  if (grain_along_y) cv::transpose(out, out);
  return out;
}

cv::Mat Fabric(Rng& rng, int size, const cv::Scalar& colour, double contrast) {
  const cv::Mat n = BandLimitedNoise(size, size, {0.5, 4.0, 0.4, 1.0}, rng);
  const cv::Mat h = BandLimitedNoise(size, size, {1.0, 2.0, 0.2, 1.0}, rng);
  return Tint(n, h, Bgr(colour), contrast, 0.4 * contrast);
}

cv::Mat Tiles(Rng& rng, int size, int tiles_per_side, const cv::Scalar& colour,
              const cv::Scalar& grout) {
  const cv::Mat n = BandLimitedNoise(size, size, {0.9, 2.0, 0.3, 1.0}, rng);
  const cv::Mat h = BandLimitedNoise(size, size, {1.5, 1.0, 0.1, 1.0}, rng);
  cv::Mat out = Tint(n, h, Bgr(colour), 6.0, 2.0);
  const int step = size / tiles_per_side;
  // Per-tile tone, then grout lines drawn at 2x and averaged down (anti-aliased).
  cv::Mat big;
  cv::resize(out, big, cv::Size(2 * size, 2 * size), 0, 0, cv::INTER_NEAREST);
  for (int ty = 0; ty < tiles_per_side; ++ty) {
    for (int tx = 0; tx < tiles_per_side; ++tx) {
      const double shift = rng.Uniform(-10, 10);
      cv::Mat tile = big(cv::Rect(2 * tx * step, 2 * ty * step, 2 * step, 2 * step));
      cv::add(tile, cv::Scalar(shift, shift, shift), tile);
    }
  }
  for (int i = 0; i <= tiles_per_side; ++i) {
    const int p = 2 * i * step;
    cv::rectangle(big, cv::Rect(p - 3, 0, 6, 2 * size), grout, cv::FILLED);
    cv::rectangle(big, cv::Rect(0, p - 3, 2 * size, 6), grout, cv::FILLED);
  }
  return Downsample2x(big);
}

cv::Mat Poster(Rng& rng, int width, int height) {
  const int W = 2 * width, H = 2 * height;
  cv::Mat big(H, W, CV_8UC3, cv::Scalar(235, 238, 240));  // paper white margin
  const int margin = std::max(W, H) / 20;
  const cv::Rect inner(margin, margin, W - 2 * margin, H - 2 * margin);
  big(inner).setTo(RandomColour(rng, 60, 230));
  const int shapes = rng.UniformInt(6, 14);
  for (int i = 0; i < shapes; ++i) {
    const cv::Scalar c = RandomColour(rng, 10, 250);
    const cv::Point p(inner.x + rng.UniformInt(0, inner.width),
                      inner.y + rng.UniformInt(0, inner.height));
    const int r = rng.UniformInt(inner.width / 20, inner.width / 5);
    switch (rng.UniformInt(0, 2)) {
      case 0:
        cv::circle(big, p, r, c, cv::FILLED, cv::LINE_AA);
        break;
      case 1:
        cv::rectangle(big, cv::Rect(p.x - r, p.y - r / 2, 2 * r, r) & inner, c, cv::FILLED,
                      cv::LINE_AA);
        break;
      default: {
        const int stripes = rng.UniformInt(3, 7);
        for (int s = 0; s < stripes; ++s) {
          cv::line(big, cv::Point(p.x - r, p.y + s * r / 3),
                   cv::Point(p.x + r, p.y + s * r / 3 - r), c, std::max(2, r / 12), cv::LINE_AA);
        }
      }
    }
  }
  // Title and body text, as printed posters have.
  const cv::Scalar ink = RandomColour(rng, 0, 60);
  const double title_scale = inner.width / 260.0;
  cv::putText(big, RandomWord(rng, 4, 8, true),
              cv::Point(inner.x + inner.width / 12, inner.y + inner.height / 6),
              cv::FONT_HERSHEY_DUPLEX, title_scale, ink,
              std::max(2, static_cast<int>(title_scale * 2)), cv::LINE_AA);
  const int lines = rng.UniformInt(5, 10);
  const double body_scale = inner.width / 700.0;
  for (int l = 0; l < lines; ++l) {
    std::string text;
    for (int w = 0; w < 4; ++w) text += RandomWord(rng, 2, 7, w == 0) + " ";
    const int y = inner.y + inner.height / 2 + l * inner.height / (2 * lines + 2);
    cv::putText(big, text, cv::Point(inner.x + inner.width / 12, y), cv::FONT_HERSHEY_SIMPLEX,
                body_scale, ink, std::max(1, static_cast<int>(body_scale * 2)), cv::LINE_AA);
  }
  return Downsample2x(big);
}

cv::Mat Books(Rng& rng, int width, int height) {
  const int W = 2 * width, H = 2 * height;
  cv::Mat big(H, W, CV_8UC3, cv::Scalar(25, 25, 30));  // the shadowed back of the shelf
  int x = 0;
  while (x < W) {
    const int w = rng.UniformInt(W / 40, W / 12);
    const int h = rng.UniformInt(H * 6 / 10, H - 2);
    const cv::Scalar c = RandomColour(rng, 30, 220);
    cv::rectangle(big, cv::Rect(x, H - h, w - 2, h), c, cv::FILLED);
    // Title band and a couple of printed lines across the spine.
    const int band_y = H - h + rng.UniformInt(h / 8, h / 3);
    cv::rectangle(big, cv::Rect(x + 2, band_y, w - 6, h / 10), RandomColour(rng, 0, 255),
                  cv::FILLED);
    cv::line(big, cv::Point(x + 3, H - h / 6), cv::Point(x + w - 5, H - h / 6),
             RandomColour(rng, 0, 255), 3, cv::LINE_AA);
    x += w + rng.UniformInt(0, 3);
  }
  return Downsample2x(big);
}

cv::Mat Toy(Rng& rng, int size) {
  const int S = 2 * size;
  cv::Mat big(S, S, CV_8UC3, RandomColour(rng, 120, 255));
  const int cells = 4;
  for (int cy = 0; cy < cells; ++cy) {
    for (int cx = 0; cx < cells; ++cx) {
      if ((cx + cy) % 2) {
        cv::rectangle(big, cv::Rect(cx * S / cells, cy * S / cells, S / cells, S / cells),
                      RandomColour(rng, 0, 120), cv::FILLED);
      }
    }
  }
  for (int i = 0; i < 10; ++i) {
    cv::circle(big, cv::Point(rng.UniformInt(0, S), rng.UniformInt(0, S)),
               rng.UniformInt(S / 20, S / 8), RandomColour(rng, 0, 255), cv::FILLED, cv::LINE_AA);
  }
  return Downsample2x(big);
}

}  // namespace epmap::sim::textures
