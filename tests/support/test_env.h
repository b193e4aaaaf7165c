#pragma once
// Where tests find things: the build's binaries, the source tree and ../shared/data.
// CTest sets EPMAP_BIN_DIR, EPMAP_SOURCE_DIR and EPMAP_SHARED_DIR (see cmake/EpmapTargets.cmake);
// a test binary run by hand falls back to the same places, compiled in by epmap_test.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <system_error>
#include <vector>

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

// A DDS domain id of this test process's own (20..219), so parallel CTest runs never cross.
// The same salt gives the same id within a process. Hashing the pid alone let two tests meet
// on one domain now and then (200 ids; a run then saw the other's samples), so each id is
// reserved across processes by an exclusive flock on a file in the temp dir, held until the
// process exits: the first free id from the hash on is taken.
inline uint32_t UniqueDomainId(uint32_t salt = 0) {
  static std::mutex mutex;
  static std::map<uint32_t, uint32_t> by_salt;
  std::lock_guard lock(mutex);
  if (const auto it = by_salt.find(salt); it != by_salt.end()) return it->second;
  const uint32_t first = (static_cast<uint32_t>(::getpid()) * 7u + salt) % 200u;
  for (uint32_t k = 0; k < 200u; ++k) {
    const uint32_t domain = (first + k) % 200u + 20u;
    const auto path = std::filesystem::temp_directory_path() /
                      ("epmap-dds-domain-" + std::to_string(domain) + ".lock");
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
    if (fd < 0) continue;
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) {
      by_salt[salt] = domain;  // fd stays open: the reservation lasts as long as the process
      return domain;
    }
    ::close(fd);
  }
  return first + 20u;  // every id taken: share one rather than fail
}

// Folders FreshTempDir made; removed when the test binary exits after every test passed, so
// repeated runs do not fill /tmp. A failed run keeps them to look at, and so does any run with
// EPMAP_KEEP_TEST_DIRS set.
class TempDirRegistry {
 public:
  static TempDirRegistry& Instance() {
    static TempDirRegistry registry;  // made after gtest's UnitTest, so destroyed before it
    return registry;
  }
  void Add(const std::filesystem::path& dir) {
    std::lock_guard<std::mutex> lock(mutex_);
    dirs_.push_back(dir);
  }
  ~TempDirRegistry() {
    const char* keep = std::getenv("EPMAP_KEEP_TEST_DIRS");
    if ((keep && *keep) || !::testing::UnitTest::GetInstance()->Passed()) return;
    for (const auto& dir : dirs_) {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  }

 private:
  TempDirRegistry() { (void)::testing::UnitTest::GetInstance(); }
  std::mutex mutex_;
  std::vector<std::filesystem::path> dirs_;
};

// A fresh empty folder under the system temp dir (see TempDirRegistry for when it goes).
inline std::filesystem::path FreshTempDir(const std::string& tag) {
  const auto dir =
      std::filesystem::temp_directory_path() /
      ("epmap-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(std::rand()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  TempDirRegistry::Instance().Add(dir);
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
