// common/process/process_memory.h: what GetStatus reports as epmapd's memory.

#include "common/process/process_memory.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>

namespace epmap {
namespace {

TEST(ProcessMemory, PeakFollowsWhatTheProcessTouches) {
  const auto before = process::ReadProcessMemory();
  ASSERT_GT(before.resident_mb, 0.0);
  EXPECT_GE(before.peak_resident_mb, before.resident_mb);
  // 64 MB written (untouched pages are not resident), held while measured.
  constexpr size_t kBytes = 64u << 20;
  auto block = std::make_unique<char[]>(kBytes);
  std::memset(block.get(), 1, kBytes);
  const auto during = process::ReadProcessMemory();
  EXPECT_GE(during.resident_mb, before.resident_mb + 56.0);
  EXPECT_GE(during.peak_resident_mb, before.resident_mb + 56.0);
  EXPECT_EQ(block[kBytes - 1], 1);
}

TEST(ProcessMemory, AProcessThatDoesNotExistReadsUnknown) {
  const auto none = process::ReadProcessMemory("999999999");
  EXPECT_EQ(none.resident_mb, -1.0);
  EXPECT_EQ(none.peak_resident_mb, -1.0);
}

}  // namespace
}  // namespace epmap
