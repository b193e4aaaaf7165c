#include "services/mapping/pipeline/stage_stats.h"

#include <gtest/gtest.h>

namespace epmap::mapping {
namespace {

// The summaries GetStatus reports: over the last `window` values, work done every fourth frame
// shows in the mean, not in the median.
TEST(RollingStats, MedianMeanAndP99OverTheWindow) {
  RollingStats stats(8);
  EXPECT_EQ(stats.Summary("share").samples, 0u);
  for (int k = 0; k < 12; ++k) stats.Add("share", k % 4 == 0 ? 0.2 : 0.0);
  const RollingSummary s = stats.Summary("share");
  EXPECT_EQ(s.samples, 12u);        // all ever added
  EXPECT_DOUBLE_EQ(s.last, 0.0);    // k = 11
  EXPECT_DOUBLE_EQ(s.median, 0.0);  // the band's frames are a quarter
  EXPECT_DOUBLE_EQ(s.mean, 0.05);   // frames 4..11: two of eight carry 0.2
  EXPECT_DOUBLE_EQ(s.p99, 0.2);
  stats.Add("share", 1.0);  // replaces the oldest of the window (k = 4, 0.2)
  EXPECT_DOUBLE_EQ(stats.Summary("share").mean, (0.2 + 1.0) / 8);
}

}  // namespace
}  // namespace epmap::mapping
