#include "perception/ep/comparator/regions.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace epmap::ep {

namespace {
// The main surface's band around the median disparity: +-max(1 px, 15%).
constexpr float kSurfaceBandPx = 1.0F;
constexpr float kSurfaceBandShare = 0.15F;
}  // namespace

std::vector<Region> LabelRegions(const cv::Mat& mask, const cv::Mat& disparity,
                                 const stereo::RectifiedGeometry& camera,
                                 const Eigen::Isometry3d& T_base_cam0) {
  if (mask.type() != CV_8UC1) throw std::invalid_argument("regions: mask must be CV_8UC1");
  if (disparity.type() != CV_32FC1 || disparity.size() != mask.size()) {
    throw std::invalid_argument("regions: disparity must be CV_32FC1 of the mask's size");
  }
  // Labelled within the box of all flagged pixels only: the regions cover a few percent of the
  // image, and a full-frame pass over 4-byte labels cost more than the rest of the labelling.
  const cv::Rect roi = cv::boundingRect(mask);
  if (roi.empty()) return {};
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask(roi), labels, stats, centroids, 8, CV_32S);
  std::vector<Region> regions(static_cast<size_t>(std::max(n - 1, 0)));
  // Each region's known disparities, by pixel: one pass to collect, one to place the points.
  std::vector<std::vector<float>> disparities(regions.size());
  for (int v = roi.y; v < roi.y + roi.height; ++v) {
    const int* l = labels.ptr<int>(v - roi.y) - roi.x;  // indexed by image column
    const float* d = disparity.ptr<float>(v);
    for (int u = roi.x; u < roi.x + roi.width; ++u) {
      if (l[u] == 0 || !(d[u] > 0) || !std::isfinite(d[u])) continue;
      disparities[static_cast<size_t>(l[u] - 1)].push_back(d[u]);
    }
  }
  // The centroid is that of the region's main surface: the points within a band around its
  // median disparity. A region on a moving thing also holds some of what lies behind its
  // edges, and z = fb / d makes a mean over all points follow the far ones (a person 2 m away
  // with a fifth of the region on a wall 15 m behind: mean z 4.6 m).
  const double fb = camera.fx * camera.baseline_m;
  const bool metric = fb > 0 && camera.fy > 0;
  std::vector<float> band_lo(regions.size()), band_hi(regions.size());
  for (size_t i = 0; i < regions.size(); ++i) {
    auto& ds = disparities[i];
    regions[i].disparity_pixels = static_cast<int>(ds.size());
    if (ds.empty()) continue;
    double sum = 0;
    for (float d : ds) sum += d;
    regions[i].mean_disparity_px = sum / static_cast<double>(ds.size());
    std::nth_element(ds.begin(), ds.begin() + static_cast<std::ptrdiff_t>(ds.size() / 2), ds.end());
    const float median = ds[ds.size() / 2];
    const float half_width = std::max(kSurfaceBandPx, kSurfaceBandShare * median);
    band_lo[i] = median - half_width;
    band_hi[i] = median + half_width;
  }
  std::vector<Eigen::Vector3d> sum_point(regions.size(), Eigen::Vector3d::Zero());
  std::vector<int> surface_pixels(regions.size(), 0);
  if (metric) {
    for (int v = roi.y; v < roi.y + roi.height; ++v) {
      const int* l = labels.ptr<int>(v - roi.y) - roi.x;
      const float* d = disparity.ptr<float>(v);
      for (int u = roi.x; u < roi.x + roi.width; ++u) {
        if (l[u] == 0 || !(d[u] > 0) || !std::isfinite(d[u])) continue;
        const auto i = static_cast<size_t>(l[u] - 1);
        if (d[u] < band_lo[i] || d[u] > band_hi[i]) continue;
        const double z = fb / d[u];
        sum_point[i] +=
            Eigen::Vector3d((u - camera.cx) / camera.fx * z, (v - camera.cy) / camera.fy * z, z);
        ++surface_pixels[i];
      }
    }
  }
  for (size_t i = 0; i < regions.size(); ++i) {
    Region& r = regions[i];
    const int label = static_cast<int>(i) + 1;
    r.box =
        cv::Rect(roi.x + stats.at<int>(label, cv::CC_STAT_LEFT),
                 roi.y + stats.at<int>(label, cv::CC_STAT_TOP),
                 stats.at<int>(label, cv::CC_STAT_WIDTH), stats.at<int>(label, cv::CC_STAT_HEIGHT));
    r.area_px = stats.at<int>(label, cv::CC_STAT_AREA);
    if (r.disparity_pixels == 0) r.mean_disparity_px = std::numeric_limits<double>::quiet_NaN();
    if (surface_pixels[i] > 0) {
      r.has_centroid = true;
      r.centroid_cam0 = sum_point[i] / surface_pixels[i];
      r.centroid_base = T_base_cam0 * r.centroid_cam0;
    }
  }
  std::stable_sort(regions.begin(), regions.end(),
                   [](const Region& a, const Region& b) { return a.area_px > b.area_px; });
  return regions;
}

}  // namespace epmap::ep
