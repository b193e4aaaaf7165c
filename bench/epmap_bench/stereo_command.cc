// epmap-bench stereo --dataset DIR [--num-disparities N]: SGBM on every frame of a dataset
// (rectified first if needed), with bad-2 against the ground truth where the dataset has it.
// A reference point for the other benchmarks: their baseline is this full-frame matcher.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "bench/epmap_bench/command_registry.h"
#include "common/dataset/dataset.h"
#include "perception/stereo/metrics.h"
#include "perception/stereo/sgbm.h"

namespace {

int Run(int argc, char** argv) {
  CLI::App app("SGBM over a dataset: timing and bad-2 vs ground truth", argv[0]);
  std::string dataset_path;
  int num_disparities = 0;
  app.add_option("--dataset", dataset_path, "dataset folder (sequence or stereo pair)")->required();
  app.add_option("--num-disparities", num_disparities, "disparity range (multiple of 16)");
  CLI11_PARSE(app, argc, argv);
  try {
    const auto d = epmap::dataset::Load(dataset_path);
    epmap::stereo::SgbmParams params;
    if (num_disparities > 0)
      params.num_disparities = num_disparities;
    else if (d.num_disparities > 0)
      params.num_disparities = d.num_disparities;
    const epmap::stereo::SgbmMatcher matcher(params);
    std::vector<double> ms;
    epmap::stereo::DisparityScore total;
    for (const auto& f : d.frames) {
      const cv::Mat l = cv::imread(f.left.string(), cv::IMREAD_UNCHANGED);
      const cv::Mat r = cv::imread(f.right.string(), cv::IMREAD_UNCHANGED);
      const auto t0 = std::chrono::steady_clock::now();
      const cv::Mat disp = matcher.Compute(l, r);
      ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      const cv::Mat gt = epmap::dataset::LoadGtDisparity(d, f.stamp_ns);
      if (!gt.empty()) {
        const auto s = epmap::stereo::ScoreDisparity(disp, gt);
        total.gt_pixels += s.gt_pixels;
        total.filled += s.filled;
        total.bad_filled += s.bad_filled;
      }
    }
    std::sort(ms.begin(), ms.end());
    std::printf("{\"command\":\"stereo\",\"frames\":%zu,\"sgbm_ms_median\":%.3f,", ms.size(),
                ms[ms.size() / 2]);
    if (total.gt_pixels) {
      std::printf("\"bad2\":%.5f,\"bad2_over_filled\":%.5f,\"filled_share\":%.5f",
                  total.bad_counting_unknown(), total.bad_over_filled(), total.filled_share());
    } else {
      std::printf("\"bad2\":null");
    }
    std::printf(",\"num_disparities\":%d}\n", params.num_disparities);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "epmap-bench stereo: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

EPMAP_BENCH_COMMAND(stereo, "stereo", "full-frame SGBM over a dataset (timing, bad-2)", Run);
