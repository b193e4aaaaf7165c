#include "clients/sim/texture.h"

#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace epmap::sim {

namespace {
bool PowerOfTwo(int v) {
  return v >= 4 && (v & (v - 1)) == 0;
}

// One pyramid step of a periodic image: pad by wrapping so the Gaussian sees the other side,
// then cv::pyrDown (5-tap Gaussian; output texel k is centred on input texel 2k).
cv::Mat WrappedPyrDown(const cv::Mat& img) {
  cv::Mat padded, down;
  cv::copyMakeBorder(img, padded, 2, 2, 2, 2, cv::BORDER_WRAP);
  cv::pyrDown(padded, down);
  return down(cv::Rect(1, 1, img.cols / 2, img.rows / 2)).clone();
}
}  // namespace

Texture::Texture(const cv::Mat& level0) {
  if (level0.type() != CV_8UC1 && level0.type() != CV_8UC3) {
    throw std::invalid_argument("Texture: level 0 must be CV_8UC1 or CV_8UC3");
  }
  if (!PowerOfTwo(level0.cols) || !PowerOfTwo(level0.rows)) {
    throw std::invalid_argument("Texture: sides must be powers of two >= 4, got " +
                                std::to_string(level0.cols) + "x" + std::to_string(level0.rows));
  }
  channels_ = level0.channels();
  std::vector<cv::Mat> pyramid = {level0.clone()};
  while (pyramid.back().cols >= 8 && pyramid.back().rows >= 8) {
    pyramid.push_back(WrappedPyrDown(pyramid.back()));
  }
  for (size_t i = 0; i < pyramid.size(); ++i) {
    cv::Mat stored;
    if (channels_ == 3) {
      cv::cvtColor(pyramid[i], stored, cv::COLOR_BGR2BGRA);
    } else {
      stored = pyramid[i];
    }
    levels_.push_back(stored);
    data_.push_back({stored.ptr<uint8_t>(), stored.step[0], stored.cols - 1, stored.rows - 1,
                     1.0 / static_cast<double>(1 << i)});
  }
}

}  // namespace epmap::sim
