// epmap-bench edges --dataset DIR [--max-frames N]: the perceptual map's edge stereo (paper 003,
// Sec. III-A) against the true disparity, the disparity of the two edge locations (default)
// beside the one refined over the matching window, on the same frames.
// Only edge points inside a smooth patch of true disparity are scored (texture edges on a face,
// not silhouettes, where the true disparity jumps); errors are grouped by true disparity, since
// at a far wall's few pixels a tenth of a pixel is a metre of depth (z = f b / d).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "bench/epmap_bench/command_registry.h"
#include "bench/epmap_bench/summary.h"
#include "common/dataset/dataset.h"
#include "perception/perceptual_map/edge_stereo.h"

namespace {

namespace pm = epmap::perceptual_map;

// The true disparity at (u, v) interpolated along the row, if the four columns around u all
// have one and they differ by at most `max_spread` px (a smooth face, not a silhouette).
bool SmoothTruthAt(const cv::Mat& gt, float u, float v, double max_spread, double* value) {
  const int r = static_cast<int>(std::lround(v));
  const int c = static_cast<int>(std::floor(u));
  if (r < 0 || r >= gt.rows || c < 1 || c + 2 >= gt.cols) return false;
  const float* row = gt.ptr<float>(r);
  float lo = row[c - 1], hi = row[c - 1];
  for (int x = c - 1; x <= c + 2; ++x) {
    if (!std::isfinite(row[x])) return false;
    lo = std::min(lo, row[x]);
    hi = std::max(hi, row[x]);
  }
  if (hi - lo > max_spread) return false;
  const double w = u - c;
  *value = row[c] * (1 - w) + row[c + 1] * w;
  return true;
}

struct ErrorBin {
  const char* name;
  double lo_px, hi_px;  // true disparity range
  std::vector<double> errors;
};

std::string BinJson(const ErrorBin& b, double f_b) {
  using epmap::bench::FormatFixed;
  std::vector<double> abs_err, beyond_1px;
  for (double e : b.errors) {
    abs_err.push_back(std::abs(e));
    beyond_1px.push_back(std::abs(e) > 1.0 ? 1.0 : 0.0);
  }
  const double median = epmap::bench::Median(abs_err);
  // Depth error of the median disparity error at the bin's middle: dz = z^2 dd / (f b).
  const double mid_d = std::isfinite(b.hi_px) ? 0.5 * (b.lo_px + b.hi_px) : 1.5 * b.lo_px;
  const double z = f_b / mid_d;
  return std::string("{\"true_disparity_px\":") + epmap::bench::JsonQuote(b.name) +
         ",\"points\":" + std::to_string(b.errors.size()) +
         ",\"median_abs_error_px\":" + FormatFixed(median, 4) +
         ",\"p90_abs_error_px\":" + FormatFixed(epmap::bench::Percentile(abs_err, 0.9), 4) +
         ",\"median_error_px\":" + FormatFixed(epmap::bench::Median(b.errors), 4) +
         ",\"mean_error_px\":" + FormatFixed(epmap::bench::Mean(b.errors), 4) +
         ",\"share_beyond_1px\":" + FormatFixed(epmap::bench::Mean(beyond_1px), 4) +
         ",\"at_range_m\":" + FormatFixed(z, 1) +
         ",\"median_depth_error_there_m\":" + FormatFixed(z * z * median / f_b, 3) + "}";
}

int Run(int argc, char** argv) {
  CLI::App app("Edge stereo of the perceptual map against the true disparity", argv[0]);
  std::string dataset_path;
  size_t max_frames = 200;
  double max_spread = 0.25;
  double max_range = pm::EdgeStereoParams{}.max_range_m;
  app.add_option("--dataset", dataset_path, "rectified dataset with gt_disparity0/")->required();
  app.add_option("--max-frames", max_frames, "score at most this many frames with ground truth");
  app.add_option("--max-spread", max_spread,
                 "true disparity may vary by this much (px) over 4 columns around a scored point");
  app.add_option("--max-range", max_range,
                 "drop edge points beyond this range (m), as the perceptual map does at 20 m; a "
                 "larger value shows the far bin without the selection the cut makes");
  CLI11_PARSE(app, argc, argv);
  try {
    const auto d = epmap::dataset::Load(dataset_path);
    if (!d.rectified()) throw std::runtime_error(dataset_path + ": needs a rectified rig");
    if (d.gt_disparity.empty()) throw std::runtime_error(dataset_path + ": no gt_disparity0/");
    const pm::StereoCamera camera{d.cam0.width, d.cam0.height, d.cam0.fu,     d.cam0.fv,
                                  d.cam0.cu,    d.cam0.cv,     d.baseline_m()};
    const double f_b = camera.fx * camera.baseline_m;
    struct Method {
      const char* name;
      double refine_px;
      bool reject_contested;
      std::vector<ErrorBin> bins;
      size_t matched = 0;
    };
    const std::vector<ErrorBin> bins = {{"<3 (far)", 0, 3, {}},
                                        {"3-6", 3, 6, {}},
                                        {"6-12", 6, 12, {}},
                                        {">=12 (near)", 12, INFINITY, {}}};
    std::vector<Method> methods = {
        {"edge locations (default)", 0.0, false, bins, 0},
        {"refined over the window (refine_disparity_px 1)", 1.0, false, bins, 0},
        {"contested matches rejected (reject_contested)", 0.0, true, bins, 0}};
    size_t frames = 0;
    for (const auto& f : d.frames) {
      if (frames >= max_frames) break;
      const cv::Mat gt = epmap::dataset::LoadGtDisparity(d, f.stamp_ns);
      if (gt.empty()) continue;
      ++frames;
      const cv::Mat l = cv::imread(f.left.string(), cv::IMREAD_UNCHANGED);
      const cv::Mat r = cv::imread(f.right.string(), cv::IMREAD_UNCHANGED);
      for (auto& m : methods) {
        pm::EdgeStereoParams p;
        p.refine_disparity_px = m.refine_px;
        p.max_range_m = max_range;
        p.reject_contested = m.reject_contested;
        const auto points = pm::MatchEdgePoints(l, r, camera, p);
        m.matched += points.size();
        for (const auto& pt : points) {
          double truth = 0;
          if (!SmoothTruthAt(gt, pt.u, pt.v, max_spread, &truth)) continue;
          for (auto& b : m.bins) {
            if (truth >= b.lo_px && truth < b.hi_px) b.errors.push_back(pt.disparity - truth);
          }
        }
      }
    }
    std::printf("{\"command\":\"edges\",\"frames\":%zu,\"f_b_px_m\":%.4f,\"methods\":[", frames,
                f_b);
    for (size_t i = 0; i < methods.size(); ++i) {
      std::printf("%s{\"disparity\":\"%s\",\"matched\":%zu,\"bins\":[", i ? "," : "",
                  methods[i].name, methods[i].matched);
      for (size_t j = 0; j < methods[i].bins.size(); ++j) {
        std::printf("%s%s", j ? "," : "", BinJson(methods[i].bins[j], f_b).c_str());
      }
      std::printf("]}");
    }
    std::printf("]}\n");
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "epmap-bench edges: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

EPMAP_BENCH_COMMAND(edges, "edges", "perceptual-map edge stereo vs the true disparity", Run);
