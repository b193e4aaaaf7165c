#pragma once
// The mobile base's maps on disk: <state.dir>/maps.sqlite3 holds the newest saved state of the
// MobileMapper (mobile_mapping::MobileMapper::SaveState: maps, poses, counters), so that a
// restarted epmapd resumes the maps instead of starting over. One row, replaced by each save,
// WAL journal, synchronous=FULL: a save that returned is on disk; a crash mid-save leaves the
// previous one. Saving runs on the store's own thread; the pipeline only hands bytes over.

#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "common/sqlite/sqlite_database.h"
#include "services/mapping/ingest/counters.h"

namespace epmap::mapping {

class MapsStore {
 public:
  static constexpr const char* kFileName = "maps.sqlite3";

  // Opens (creating) <dir>/maps.sqlite3. Throws std::runtime_error (sqlite::Error for the
  // database) with the reason when the folder or the database cannot be made. Saves are counted in
  // events as maps_saved and maps_save_failed (the reason logged).
  MapsStore(const std::filesystem::path& dir, CounterSet& events);
  ~MapsStore();  // writes what is pending, then closes
  MapsStore(const MapsStore&) = delete;
  MapsStore& operator=(const MapsStore&) = delete;

  struct Saved {
    std::string bytes;
    int64_t saved_unix_ns = 0;  // wall clock of the save
    uint64_t key_frames = 0;    // accepted key frames in the saved maps
  };
  // The newest saved maps, or nothing. Throws std::runtime_error when the database cannot be read.
  std::optional<Saved> Load() const;

  // Hands a state to the writer thread; a state not yet written is replaced (the newest wins).
  void Offer(std::string bytes, uint64_t key_frames);
  // Returns once every offered state is written (or failed).
  void Flush();
  // Forgets the saved maps: a state offered and not yet written is dropped, one being written
  // is waited for, then the row is deleted. Throws std::runtime_error when it cannot delete.
  void Clear();

  const std::filesystem::path& path() const { return db_.path(); }

  // What is on disk now (for GetStatus): the newest save, found at opening or written since;
  // nothing when no maps are saved (none yet, or cleared). Any thread.
  struct Summary {
    int64_t saved_unix_ns = 0;
    uint64_t key_frames = 0;
    uint64_t bytes = 0;
  };
  std::optional<Summary> OnDisk() const;

 private:
  void Run();
  void Write(const std::string& bytes, uint64_t key_frames);

  CounterSet& events_;
  sqlite::Database db_;
  mutable std::mutex db_mutex_;
  mutable std::mutex on_disk_mutex_;
  std::optional<Summary> on_disk_;

  std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<std::pair<std::string, uint64_t>> pending_;
  bool writing_ = false;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace epmap::mapping
