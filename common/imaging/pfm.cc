#include "common/imaging/pfm.h"

#include <bit>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace epmap::imaging {

void WritePfm(const std::filesystem::path& path, const cv::Mat& image) {
  if (image.type() != CV_32FC1) {
    throw std::runtime_error("WritePfm: expected a CV_32FC1 image");
  }
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("WritePfm: cannot open " + path.string());
  // Negative scale = little-endian.
  out << "Pf\n" << image.cols << " " << image.rows << "\n-1\n";
  static_assert(std::endian::native == std::endian::little, "PFM writer assumes little-endian");
  for (int r = image.rows - 1; r >= 0; --r) {
    out.write(reinterpret_cast<const char*>(image.ptr<float>(r)),
              static_cast<std::streamsize>(image.cols * sizeof(float)));
  }
  if (!out) throw std::runtime_error("WritePfm: write failed for " + path.string());
}

cv::Mat ReadPfm(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("ReadPfm: cannot open " + path.string());
  std::string magic;
  int width = 0;
  int height = 0;
  double scale = 0.0;
  in >> magic >> width >> height >> scale;
  in.get();  // the single whitespace after the scale
  if (!in || magic != "Pf") {
    throw std::runtime_error("ReadPfm: " + path.string() + " is not a single-channel PFM");
  }
  if (width <= 0 || height <= 0 || width > 1 << 15 || height > 1 << 15 || scale == 0.0) {
    throw std::runtime_error("ReadPfm: bad header in " + path.string());
  }
  const bool big_endian = scale > 0;
  cv::Mat image(height, width, CV_32FC1);
  for (int r = height - 1; r >= 0; --r) {
    in.read(reinterpret_cast<char*>(image.ptr<float>(r)),
            static_cast<std::streamsize>(width * sizeof(float)));
  }
  if (!in) throw std::runtime_error("ReadPfm: truncated data in " + path.string());
  if (big_endian) {
    for (int r = 0; r < height; ++r) {
      auto* row = image.ptr<uint32_t>(r);
      for (int c = 0; c < width; ++c) row[c] = __builtin_bswap32(row[c]);
    }
  }
  return image;
}

}  // namespace epmap::imaging
