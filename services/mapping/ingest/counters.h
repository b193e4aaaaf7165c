#pragma once
// Named counters shared between DDS listener threads, the pipeline and the API: every sample
// the service refuses, every frame it drops, is counted under a reason a person can read.

#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace epmap::mapping {

class CounterSet {
 public:
  void Increment(const std::string& reason, uint64_t by = 1) {
    std::lock_guard lock(mutex_);
    counts_[reason] += by;
  }
  void Set(const std::string& reason, uint64_t value) {
    std::lock_guard lock(mutex_);
    counts_[reason] = value;
  }
  uint64_t Get(const std::string& reason) const {
    std::lock_guard lock(mutex_);
    const auto it = counts_.find(reason);
    return it == counts_.end() ? 0 : it->second;
  }
  uint64_t Total() const {
    std::lock_guard lock(mutex_);
    uint64_t total = 0;
    for (const auto& [_, n] : counts_) total += n;
    return total;
  }
  std::vector<std::pair<std::string, uint64_t>> Snapshot() const {
    std::lock_guard lock(mutex_);
    return {counts_.begin(), counts_.end()};
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, uint64_t> counts_;
};

}  // namespace epmap::mapping
