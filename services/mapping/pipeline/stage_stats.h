#pragma once
// Rolling statistics of per-stage durations (and any other per-frame figure): the last N
// values, their median, mean and 99th percentile. Thread-safe: the pipeline writes, the API reads.

#include <algorithm>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace epmap::mapping {

struct RollingSummary {
  double last = 0;
  double median = 0;
  double mean = 0;  // what work done every few frames costs on average (the median hides it)
  double p99 = 0;
  uint64_t samples = 0;
};

class RollingStats {
 public:
  explicit RollingStats(size_t window = 256) : window_(window) {}

  void Add(const std::string& name, double value) {
    std::lock_guard lock(mutex_);
    auto& series = series_[name];
    if (series.values.size() < window_) {
      series.values.push_back(value);
    } else {
      series.values[series.next] = value;
    }
    series.next = (series.next + 1) % window_;
    series.last = value;
    series.count++;
  }

  std::map<std::string, RollingSummary> Summaries() const {
    std::lock_guard lock(mutex_);
    std::map<std::string, RollingSummary> out;
    for (const auto& [name, series] : series_) out[name] = Summarise(series);
    return out;
  }

  RollingSummary Summary(const std::string& name) const {
    std::lock_guard lock(mutex_);
    const auto it = series_.find(name);
    return it == series_.end() ? RollingSummary{} : Summarise(it->second);
  }

 private:
  struct Series {
    std::vector<double> values;
    size_t next = 0;
    double last = 0;
    uint64_t count = 0;
  };
  static RollingSummary Summarise(const Series& s) {
    RollingSummary r;
    r.last = s.last;
    r.samples = s.count;
    if (s.values.empty()) return r;
    std::vector<double> sorted = s.values;
    std::sort(sorted.begin(), sorted.end());
    r.median = sorted[sorted.size() / 2];
    double sum = 0;
    for (const double v : sorted) sum += v;
    r.mean = sum / static_cast<double>(sorted.size());
    r.p99 = sorted[std::min(sorted.size() - 1, (sorted.size() * 99) / 100)];
    return r;
  }

  const size_t window_;
  mutable std::mutex mutex_;
  std::map<std::string, Series> series_;
};

}  // namespace epmap::mapping
