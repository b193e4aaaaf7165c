#pragma once
// The calibration service's durable state: one SQLite database (WAL journal) in the configured
// state folder holding the eye-hand samples, the jobs, the models they yielded, the active model
// of each kind and the activation history that RollbackModel walks back.
//
// Durability: every write is one transaction committed with synchronous=FULL before the call
// returns, so whatever a caller was told is stored survives kill -9 and power loss alike (WAL
// with synchronous=NORMAL would survive kill -9 too, but could lose the last commits on power
// loss; the fsync per commit costs a few ms and samples arrive in batches).
// Thread-safe: one connection behind a mutex. A second process opening the same folder is
// refused (an advisory lock, released by the kernel when its holder dies).

#include <epmap/v1/calibration_service.pb.h>

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/sqlite/sqlite_database.h"
#include "perception/calibration/eye_hand_samples.h"

namespace epmap::mapping {

// How a store operation failed; the service maps the code onto a gRPC status.
class StoreError : public std::runtime_error {
 public:
  enum class Code { kNotFound, kFailedPrecondition, kInternal };
  StoreError(Code code, const std::string& message) : std::runtime_error(message), code_(code) {}
  Code code() const { return code_; }

 private:
  Code code_;
};

class CalibrationStore {
 public:
  static constexpr const char* kFileName = "calibration.sqlite3";

  // Opens (creating) <dir>/calibration.sqlite3. Throws StoreError(kInternal) with the reason if
  // the folder cannot be created or another process holds it, sqlite::Error if the database
  // cannot be opened. Any call below throws sqlite::Error (a std::runtime_error naming the file)
  // when the database itself fails; StoreError is for what the data says.
  explicit CalibrationStore(const std::filesystem::path& dir);
  ~CalibrationStore();
  CalibrationStore(const CalibrationStore&) = delete;
  CalibrationStore& operator=(const CalibrationStore&) = delete;

  const std::filesystem::path& path() const { return db_.path(); }

  // --- samples ---
  struct AddResult {
    uint64_t stored = 0;
    uint64_t set_total = 0;
  };
  // Appends the samples to `set` in one transaction (the caller validated them).
  AddResult AddSamples(const std::string& set, const std::vector<calibration::EyeHandSample>& s);
  // In insertion order; an empty `set` means every set.
  std::vector<calibration::EyeHandSample> Samples(const std::string& set) const;
  struct SetInfo {
    std::string name;
    uint64_t count = 0;
    uint32_t paths = 0;
  };
  std::vector<SetInfo> SampleSets() const;
  uint64_t DeleteSamples(const std::string& set);

  // --- jobs ---
  // Persists a new QUEUED job (id "job-<n>") and returns it.
  v1::Job CreateJob(v1::JobKind kind, const v1::JobSpec& spec, bool activate_on_success,
                    int64_t now_ns);
  // Writes the job's state, stage, progress, message, times and errors (not its spec).
  void UpdateJob(const v1::Job& job);
  std::optional<v1::Job> GetJob(const std::string& id) const;
  // Newest first.
  std::vector<v1::Job> ListJobs(uint32_t limit) const;
  // Jobs a previous process left QUEUED or RUNNING (it crashed or was killed) become
  // INTERRUPTED with a message saying so. Returns how many.
  int InterruptUnfinishedJobs(int64_t now_ns);

  // --- models ---
  // In one transaction: stores `model` as the next version of its kind (id "<kind>-<version>"),
  // marks `job` SUCCEEDED with that model id, and activates the model if asked. Returns the
  // model as stored; `job` is updated in place.
  v1::Model FinishJobWithModel(v1::Job& job, v1::Model model, bool activate, int64_t now_ns);
  std::optional<v1::Model> GetModel(const std::string& id) const;
  // Oldest first; JOB_KIND_UNSPECIFIED = every kind.
  std::vector<v1::Model> ListModels(v1::JobKind kind) const;
  // The active model of a kind, if any.
  std::optional<v1::Model> ActiveModel(v1::JobKind kind) const;
  // Makes `id` the active model of its kind and records the activation. Throws
  // StoreError(kNotFound) for an unknown id. Activating the active model changes nothing.
  v1::Model Activate(const std::string& id, int64_t now_ns);
  // Undoes the newest activation of `kind`: the model active before it becomes active again,
  // or none (nullopt) if it was the first. Throws StoreError(kFailedPrecondition) when no model
  // of that kind is active.
  std::optional<v1::Model> Rollback(v1::JobKind kind, int64_t now_ns);

 private:
  std::optional<std::string> ActiveModelId(v1::JobKind kind) const;  // caller holds mutex_
  void ActivateLocked(const std::string& id, v1::JobKind kind, int64_t now_ns);
  void WriteJobLocked(const v1::Job& job);

  // An advisory lock on <dir>/calibration.lock (creating the folder), held while the store
  // lives; the kernel releases it when the process dies.
  struct FolderLock {
    explicit FolderLock(const std::filesystem::path& dir);
    ~FolderLock();
    FolderLock(const FolderLock&) = delete;
    FolderLock& operator=(const FolderLock&) = delete;
    int fd = -1;
  };

  FolderLock folder_lock_;
  sqlite::Database db_;
  mutable std::mutex mutex_;
};

}  // namespace epmap::mapping
