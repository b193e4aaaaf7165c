#include "services/mapping/maps_store/maps_store.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <stdexcept>

namespace epmap::mapping {

namespace {

// Schema version 1. The state is mobile_mapping's own versioned binary format.
constexpr const char* kSchema = R"sql(
PRAGMA journal_mode = WAL;
PRAGMA synchronous = FULL;
CREATE TABLE IF NOT EXISTS maps (
  slot INTEGER PRIMARY KEY CHECK (slot = 0),
  saved_unix_ns INTEGER NOT NULL,
  key_frames INTEGER NOT NULL,
  state BLOB NOT NULL);
PRAGMA user_version = 1;
)sql";

// The folder first: SQLite does not make it.
std::filesystem::path InFolder(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    throw std::runtime_error("maps store: cannot create " + dir.string() + ": " + ec.message());
  }
  return dir / MapsStore::kFileName;
}

}  // namespace

MapsStore::MapsStore(const std::filesystem::path& dir, CounterSet& events)
    : events_(events), db_(InFolder(dir)) {
  db_.Exec(kSchema);
  sqlite::Statement s(db_, "SELECT saved_unix_ns, key_frames, length(state) FROM maps");
  if (s.Step()) {
    on_disk_ = Summary{s.Int(0), static_cast<uint64_t>(s.Int(1)), static_cast<uint64_t>(s.Int(2))};
  }
  thread_ = std::thread([this] { Run(); });
}

std::optional<MapsStore::Summary> MapsStore::OnDisk() const {
  std::lock_guard lock(on_disk_mutex_);
  return on_disk_;
}

MapsStore::~MapsStore() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::optional<MapsStore::Saved> MapsStore::Load() const {
  std::lock_guard lock(db_mutex_);
  sqlite::Statement s(db_, "SELECT state, saved_unix_ns, key_frames FROM maps WHERE slot = 0");
  if (!s.Step()) return std::nullopt;
  Saved saved;
  saved.bytes = s.Blob(0);
  saved.saved_unix_ns = s.Int(1);
  saved.key_frames = static_cast<uint64_t>(s.Int(2));
  return saved;
}

void MapsStore::Offer(std::string bytes, uint64_t key_frames) {
  {
    std::lock_guard lock(mutex_);
    pending_.emplace(std::move(bytes), key_frames);
  }
  changed_.notify_all();
}

void MapsStore::Flush() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return (!pending_ && !writing_) || stop_; });
}

void MapsStore::Clear() {
  {
    std::unique_lock lock(mutex_);
    pending_.reset();
    changed_.wait(lock, [&] { return !writing_ || stop_; });
  }
  std::lock_guard lock(db_mutex_);
  db_.Exec("DELETE FROM maps");
  std::lock_guard on_disk(on_disk_mutex_);
  on_disk_.reset();
}

void MapsStore::Run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [&] { return pending_.has_value() || stop_; });
    if (!pending_) return;  // stopping, nothing left to write
    auto [bytes, key_frames] = std::move(*pending_);
    pending_.reset();
    writing_ = true;
    lock.unlock();
    Write(bytes, key_frames);
    lock.lock();
    writing_ = false;
    changed_.notify_all();
  }
}

void MapsStore::Write(const std::string& bytes, uint64_t key_frames) {
  try {
    std::lock_guard lock(db_mutex_);
    const int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
    sqlite::Statement(db_,
                      "INSERT OR REPLACE INTO maps (slot, saved_unix_ns, key_frames, state) "
                      "VALUES (0, ?1, ?2, ?3)")
        .Bind(1, now)
        .Bind(2, static_cast<int64_t>(key_frames))
        .BindBlob(3, bytes)
        .Run();
    {
      std::lock_guard on_disk(on_disk_mutex_);
      on_disk_ = Summary{now, key_frames, bytes.size()};
    }
    events_.Increment("maps_saved");
  } catch (const std::exception& e) {
    // The maps in memory are intact; the next save tries again.
    events_.Increment("maps_save_failed");
    spdlog::warn("maps: cannot save the maps: {}", e.what());
  }
}

}  // namespace epmap::mapping
