#pragma once
// Where tests find things: the build's binaries, the source tree and ../shared/data.
// CTest sets EPMAP_BIN_DIR, EPMAP_SOURCE_DIR and EPMAP_SHARED_DIR (see cmake/EpmapTargets.cmake);
// a test binary run by hand falls back to the same places, compiled in by epmap_test.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#ifndef EPMAP_DEFAULT_BIN_DIR
#define EPMAP_DEFAULT_BIN_DIR "build/bin"
#define EPMAP_DEFAULT_SOURCE_DIR "."
#define EPMAP_DEFAULT_SHARED_DIR "../shared"
#endif

namespace epmap::testing {

inline std::filesystem::path EnvPath(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return std::filesystem::path(v && *v ? v : fallback);
}

inline std::filesystem::path BinDir() {
  return EnvPath("EPMAP_BIN_DIR", EPMAP_DEFAULT_BIN_DIR);
}
inline std::filesystem::path SourceDir() {
  return EnvPath("EPMAP_SOURCE_DIR", EPMAP_DEFAULT_SOURCE_DIR);
}
inline std::filesystem::path SharedDataDir() {
  return EnvPath("EPMAP_SHARED_DIR", EPMAP_DEFAULT_SHARED_DIR) / "data";
}

// A DDS domain id of this test process's own (0..232), so parallel CTest runs never cross.
inline uint32_t UniqueDomainId(uint32_t salt = 0) {
  return static_cast<uint32_t>((static_cast<uint32_t>(::getpid()) * 7u + salt) % 200u) + 20u;
}

// A fresh empty folder under the system temp dir, removed by the caller if wanted.
inline std::filesystem::path FreshTempDir(const std::string& tag) {
  const auto dir =
      std::filesystem::temp_directory_path() /
      ("epmap-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(std::rand()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace epmap::testing

// Skips the current test with a clear message when ../shared/data is not there (a user's
// machine without the project's shared data still passes the suite).
#define EPMAP_REQUIRE_SHARED_DATA(relative)                                                    \
  do {                                                                                         \
    const auto _p = ::epmap::testing::SharedDataDir() / (relative);                            \
    if (!std::filesystem::exists(_p)) {                                                        \
      GTEST_SKIP() << "shared data not found at " << _p << " (set EPMAP_SHARED_DIR); skipped"; \
    }                                                                                          \
  } while (0)
