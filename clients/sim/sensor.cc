#include "clients/sim/sensor.h"

#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace epmap::sim {

cv::Mat Expose(const cv::Mat& radiance, double gain, const SensorModel& sensor, Rng rng) {
  if (radiance.depth() != CV_32F || (radiance.channels() != 1 && radiance.channels() != 3)) {
    throw std::invalid_argument("Expose: radiance must be CV_32FC1 or CV_32FC3");
  }
  thread_local cv::Mat blur_buffer;  // reused on this thread (see stereo_shot.cc)
  const cv::Mat* blurred = &radiance;
  if (sensor.blur_sigma_px > 0) {
    cv::GaussianBlur(radiance, blur_buffer, cv::Size(0, 0), sensor.blur_sigma_px, 0,
                     cv::BORDER_REPLICATE);
    blurred = &blur_buffer;
  }
  // Gaussian samples from a table indexed by random bits: drawing a fresh normal per channel
  // and pixel would cost more than rendering the image.
  constexpr int kTableBits = 12;
  std::array<float, 1 << kTableBits> table{};
  for (float& v : table) v = static_cast<float>(sensor.noise_sigma * rng.Gaussian());
  const bool noisy = sensor.noise_sigma > 0;

  cv::Mat out(radiance.size(), CV_8UC(radiance.channels()));
  const int values_per_row = radiance.cols * radiance.channels();
  const float g = static_cast<float>(gain);
  uint64_t bits = 0;
  int bits_left = 0;
  for (int y = 0; y < radiance.rows; ++y) {
    const float* in = blurred->ptr<float>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int i = 0; i < values_per_row; ++i) {
      float v = in[i] * g;
      if (noisy) {
        if (bits_left < kTableBits) {
          bits = rng.Next();
          bits_left = 64;
        }
        v += table[bits & ((1u << kTableBits) - 1)];
        bits >>= kTableBits;
        bits_left -= kTableBits;
      }
      o[i] = cv::saturate_cast<uint8_t>(v);  // rounds to nearest
    }
  }
  return out;
}

}  // namespace epmap::sim
