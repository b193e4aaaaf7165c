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

std::string Error(sqlite3* db, const std::string& what) {
  return "maps store: " + what + ": " + (db ? sqlite3_errmsg(db) : "out of memory");
}

// A prepared statement, finalised on scope exit.
struct Statement {
  Statement(sqlite3* db, const char* sql) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt, nullptr) != SQLITE_OK) {
      throw std::runtime_error(Error(db, "cannot prepare"));
    }
  }
  ~Statement() { sqlite3_finalize(stmt); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  sqlite3_stmt* stmt = nullptr;
};

}  // namespace

MapsStore::MapsStore(const std::filesystem::path& dir, CounterSet& events)
    : path_(dir / kFileName), events_(events) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec)
    throw std::runtime_error("maps store: cannot create " + dir.string() + ": " + ec.message());
  if (sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) !=
      SQLITE_OK) {
    const std::string message = Error(db_, "cannot open " + path_.string());
    sqlite3_close(db_);
    throw std::runtime_error(message);
  }
  sqlite3_busy_timeout(db_, 2000);
  char* error = nullptr;
  if (sqlite3_exec(db_, kSchema, nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message =
        "maps store: " + path_.string() + ": " + (error ? error : "unknown error");
    sqlite3_free(error);
    sqlite3_close(db_);
    throw std::runtime_error(message);
  }
  thread_ = std::thread([this] { Run(); });
}

MapsStore::~MapsStore() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
  sqlite3_close(db_);
}

std::optional<MapsStore::Saved> MapsStore::Load() const {
  std::lock_guard lock(db_mutex_);
  Statement s(db_, "SELECT state, saved_unix_ns, key_frames FROM maps WHERE slot = 0");
  const int rc = sqlite3_step(s.stmt);
  if (rc == SQLITE_DONE) return std::nullopt;
  if (rc != SQLITE_ROW) throw std::runtime_error(Error(db_, "cannot read the saved maps"));
  Saved saved;
  const auto* blob = static_cast<const char*>(sqlite3_column_blob(s.stmt, 0));
  saved.bytes.assign(blob ? blob : "", static_cast<size_t>(sqlite3_column_bytes(s.stmt, 0)));
  saved.saved_unix_ns = sqlite3_column_int64(s.stmt, 1);
  saved.key_frames = static_cast<uint64_t>(sqlite3_column_int64(s.stmt, 2));
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
  if (sqlite3_exec(db_, "DELETE FROM maps", nullptr, nullptr, nullptr) != SQLITE_OK) {
    throw std::runtime_error(Error(db_, "cannot clear the saved maps"));
  }
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
    Statement s(db_,
                "INSERT OR REPLACE INTO maps (slot, saved_unix_ns, key_frames, state) "
                "VALUES (0, ?1, ?2, ?3)");
    const int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
    if (sqlite3_bind_int64(s.stmt, 1, now) != SQLITE_OK ||
        sqlite3_bind_int64(s.stmt, 2, static_cast<int64_t>(key_frames)) != SQLITE_OK ||
        sqlite3_bind_blob64(s.stmt, 3, bytes.data(), bytes.size(), SQLITE_STATIC) != SQLITE_OK ||
        sqlite3_step(s.stmt) != SQLITE_DONE) {
      throw std::runtime_error(Error(db_, "cannot save the maps"));
    }
    events_.Increment("maps_saved");
  } catch (const std::exception& e) {
    // The maps in memory are intact; the next save tries again.
    events_.Increment("maps_save_failed");
    spdlog::warn("{}", e.what());
  }
}

}  // namespace epmap::mapping
