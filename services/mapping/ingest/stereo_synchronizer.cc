#include "services/mapping/ingest/stereo_synchronizer.h"

#include <cstdlib>
#include <iterator>

namespace epmap::mapping {

namespace {
const char* SideName(int side) {
  return side == 0 ? "left_image" : "right_image";
}
constexpr size_t kMaxPending = 16;  // per side; bounds memory if one camera goes silent
}  // namespace

StereoSynchronizer::StereoSynchronizer(int64_t tolerance_ns, int64_t timeout_ns,
                                       CounterSet& rejected)
    : tolerance_ns_(tolerance_ns), timeout_ns_(timeout_ns), rejected_(rejected) {}

std::optional<StereoFrame> StereoSynchronizer::Add(Side side, int64_t stamp_ns, cv::Mat image,
                                                   std::string frame_id) {
  const int me = side == Side::kLeft ? 0 : 1;
  const int other = 1 - me;
  std::lock_guard lock(mutex_);
  if (stamp_ns <= last_stamp_[me]) {
    rejected_.Increment(std::string(SideName(me)) + ":stamp_not_increasing");
    return std::nullopt;
  }
  last_stamp_[me] = stamp_ns;
  ExpireOlderThan(stamp_ns - timeout_ns_);

  // The partner with the closest stamp within tolerance.
  auto& candidates = pending_[other];
  auto best = candidates.end();
  int64_t best_gap = tolerance_ns_ + 1;
  for (auto it = candidates.lower_bound(stamp_ns - tolerance_ns_);
       it != candidates.end() && it->first <= stamp_ns + tolerance_ns_; ++it) {
    const int64_t gap = std::llabs(it->first - stamp_ns);
    if (gap < best_gap) {
      best_gap = gap;
      best = it;
    }
  }
  if (best == candidates.end()) {
    if (pending_[me].size() >= kMaxPending) {
      pending_[me].erase(pending_[me].begin());
      rejected_.Increment(std::string(SideName(me)) + ":unpaired");
    }
    pending_[me].emplace(stamp_ns, Pending{std::move(image), std::move(frame_id)});
    return std::nullopt;
  }
  Pending partner = std::move(best->second);
  const int64_t pair_stamp = me == 0 ? stamp_ns : best->first;
  // Older images of the other side can never pair now.
  const size_t orphans = static_cast<size_t>(std::distance(candidates.begin(), best));
  if (orphans) rejected_.Increment(std::string(SideName(other)) + ":unpaired", orphans);
  candidates.erase(candidates.begin(), std::next(best));
  if (partner.image.size() != image.size() || partner.image.type() != image.type()) {
    rejected_.Increment("pair:size_mismatch");
    return std::nullopt;
  }
  if (pair_stamp <= last_paired_stamp_) {
    rejected_.Increment("pair:stamp_not_increasing");
    return std::nullopt;
  }
  last_paired_stamp_ = pair_stamp;
  StereoFrame frame;
  frame.sequence = ++sequence_;
  frame.stamp_ns = pair_stamp;
  frame.left = me == 0 ? std::move(image) : std::move(partner.image);
  frame.right = me == 0 ? std::move(partner.image) : std::move(image);
  frame.frame_id = me == 0 ? std::move(frame_id) : std::move(partner.frame_id);
  frame.assembled = std::chrono::steady_clock::now();
  return frame;
}

void StereoSynchronizer::ExpireOlderThan(int64_t stamp_ns) {
  for (int side = 0; side < 2; ++side) {
    auto& pending = pending_[side];
    while (!pending.empty() && pending.begin()->first < stamp_ns) {
      pending.erase(pending.begin());
      rejected_.Increment(std::string(SideName(side)) + ":unpaired");
    }
  }
}

}  // namespace epmap::mapping
