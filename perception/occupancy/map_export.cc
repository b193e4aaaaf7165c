#include "perception/occupancy/map_export.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace epmap::occupancy {

namespace {

void CheckSize(const GridExport& g) {
  const size_t n = static_cast<size_t>(g.width) * g.height;
  if (g.occupancy.size() != n || g.confidence.size() != n) {
    throw std::invalid_argument("grid export: data size does not match width x height");
  }
}

}  // namespace

std::string EncodePgm(const GridExport& g) {
  CheckSize(g);
  std::string out = "P5\n" + std::to_string(g.width) + " " + std::to_string(g.height) + "\n255\n";
  out.reserve(out.size() + g.occupancy.size());
  for (uint32_t row = 0; row < g.height; ++row) {
    const uint32_t r = g.height - 1 - row;  // image top = highest y
    for (uint32_t c = 0; c < g.width; ++c) {
      const uint8_t occ = g.occupancy[static_cast<size_t>(r) * g.width + c];
      const int pixel = occ == GridExport::kUnknown
                            ? 205
                            : static_cast<int>(std::lround(255.0 * (1.0 - occ / 100.0)));
      out.push_back(static_cast<char>(pixel));
    }
  }
  return out;
}

std::string MapServerYaml(const GridExport& g, const std::string& image,
                          const MapServerThresholds& t) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "image: %s\nresolution: %.6f\norigin: [%.6f, %.6f, 0.0]\nnegate: 0\n"
                "occupied_thresh: %.3f\nfree_thresh: %.3f\n",
                image.c_str(), g.resolution_m, g.origin_x, g.origin_y, t.occupied, t.free);
  return buf;
}

cv::Mat RenderGrid(const GridExport& g, int scale) {
  CheckSize(g);
  if (scale < 1) throw std::invalid_argument("RenderGrid: scale must be >= 1");
  cv::Mat img(static_cast<int>(g.height), static_cast<int>(g.width), CV_8UC3);
  for (uint32_t r = 0; r < g.height; ++r) {
    auto* row = img.ptr<cv::Vec3b>(static_cast<int>(g.height - 1 - r));
    for (uint32_t c = 0; c < g.width; ++c) {
      const size_t i = static_cast<size_t>(r) * g.width + c;
      const uint8_t occ = g.occupancy[i];
      if (occ == GridExport::kUnknown) {
        row[c] = cv::Vec3b(150, 150, 150);
        continue;
      }
      const double v = 255.0 * (1.0 - occ / 100.0);
      const double k = g.confidence[i] / 255.0;
      // Grey level from the occupancy, a blue tint fading as confidence grows.
      row[c] = cv::Vec3b(static_cast<uint8_t>(v),
                         static_cast<uint8_t>(std::clamp(v * (0.75 + 0.25 * k), 0.0, 255.0)),
                         static_cast<uint8_t>(std::clamp(v * (0.6 + 0.4 * k), 0.0, 255.0)));
    }
  }
  cv::Mat big;
  cv::resize(img, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
  return big;
}

}  // namespace epmap::occupancy
