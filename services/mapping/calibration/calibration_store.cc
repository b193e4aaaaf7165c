#include "services/mapping/calibration/calibration_store.h"

#include <fcntl.h>
#include <google/protobuf/util/json_util.h>
#include <sys/file.h>
#include <unistd.h>

#include <set>
#include <utility>

#include "common/sqlite/sqlite_database.h"
#include "services/mapping/api/proto_conversions.h"

namespace epmap::mapping {

namespace {

using Code = StoreError::Code;

// The schema, version 1. Readable with the sqlite3 shell: specs and errors are JSON text.
constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS samples (
  id INTEGER PRIMARY KEY,
  set_name TEXT NOT NULL,
  stamp_ns INTEGER NOT NULL,
  xa REAL NOT NULL, ya REAL NOT NULL, za REAL NOT NULL,
  xb REAL NOT NULL, yb REAL NOT NULL, zb REAL NOT NULL,
  path TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS samples_by_set ON samples(set_name, id);
CREATE TABLE IF NOT EXISTS jobs (
  id TEXT PRIMARY KEY,
  seq INTEGER UNIQUE NOT NULL,
  kind INTEGER NOT NULL,
  spec_json TEXT NOT NULL,
  activate_on_success INTEGER NOT NULL,
  state INTEGER NOT NULL,
  stage TEXT NOT NULL DEFAULT '',
  progress REAL NOT NULL DEFAULT 0,
  iteration INTEGER NOT NULL DEFAULT 0,
  cost REAL NOT NULL DEFAULT 0,
  message TEXT NOT NULL DEFAULT '',
  model_id TEXT NOT NULL DEFAULT '',
  created_ns INTEGER NOT NULL,
  started_ns INTEGER NOT NULL DEFAULT 0,
  finished_ns INTEGER NOT NULL DEFAULT 0,
  errors_json TEXT NOT NULL DEFAULT '{}');
CREATE TABLE IF NOT EXISTS models (
  id TEXT PRIMARY KEY,
  kind INTEGER NOT NULL,
  version INTEGER NOT NULL,
  job_id TEXT NOT NULL,
  created_ns INTEGER NOT NULL,
  errors_json TEXT NOT NULL,
  description TEXT NOT NULL,
  parameters_json TEXT NOT NULL,
  UNIQUE(kind, version));
CREATE TABLE IF NOT EXISTS active_models (
  kind INTEGER PRIMARY KEY,
  model_id TEXT NOT NULL REFERENCES models(id));
CREATE TABLE IF NOT EXISTS activation_history (
  seq INTEGER PRIMARY KEY AUTOINCREMENT,
  kind INTEGER NOT NULL,
  model_id TEXT NOT NULL REFERENCES models(id),
  activated_ns INTEGER NOT NULL);
PRAGMA user_version = 1;
)sql";

using sqlite::Statement;
using sqlite::Transaction;

std::string ToJson(const google::protobuf::Message& m) {
  std::string out;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  (void)google::protobuf::util::MessageToJsonString(m, &out, options);
  return out;
}

template <class M>
M FromJson(const std::string& json) {
  M m;
  (void)google::protobuf::util::JsonStringToMessage(json, &m);
  return m;
}

constexpr const char* kJobColumns =
    "id, kind, spec_json, activate_on_success, state, stage, progress, iteration, cost, message, "
    "model_id, created_ns, started_ns, finished_ns, errors_json";

v1::Job ReadJob(const Statement& s) {
  v1::Job j;
  j.set_id(s.Text(0));
  j.set_kind(static_cast<v1::JobKind>(s.Int(1)));
  *j.mutable_spec() = FromJson<v1::JobSpec>(s.Text(2));
  j.set_activate_on_success(s.Int(3) != 0);
  j.set_state(static_cast<v1::JobState>(s.Int(4)));
  j.set_stage(s.Text(5));
  j.set_progress(s.Real(6));
  j.set_iteration(static_cast<uint64_t>(s.Int(7)));
  j.set_cost(s.Real(8));
  j.set_message(s.Text(9));
  j.set_model_id(s.Text(10));
  j.set_created_ns(s.Int(11));
  j.set_started_ns(s.Int(12));
  j.set_finished_ns(s.Int(13));
  *j.mutable_errors() = FromJson<v1::ModelErrors>(s.Text(14));
  return j;
}

constexpr const char* kModelColumns =
    "id, kind, version, job_id, created_ns, errors_json, description, parameters_json";

v1::Model ReadModel(const Statement& s) {
  v1::Model m;
  m.set_id(s.Text(0));
  m.set_kind(static_cast<v1::JobKind>(s.Int(1)));
  m.set_version(static_cast<uint32_t>(s.Int(2)));
  m.set_job_id(s.Text(3));
  m.set_created_ns(s.Int(4));
  *m.mutable_errors() = FromJson<v1::ModelErrors>(s.Text(5));
  m.set_description(s.Text(6));
  m.set_parameters_json(s.Text(7));
  return m;
}

}  // namespace

CalibrationStore::FolderLock::FolderLock(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    throw StoreError(Code::kInternal,
                     "cannot create the state folder " + dir.string() + ": " + ec.message());
  }
  // One process per state folder: two writers would interleave job ids and activations.
  const auto lock_path = dir / "calibration.lock";
  fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0 || ::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    if (fd >= 0) ::close(fd);
    throw StoreError(Code::kInternal, "the state folder " + dir.string() +
                                          " is in use by another epmapd (or not writable)");
  }
}

CalibrationStore::FolderLock::~FolderLock() {
  ::close(fd);
}

CalibrationStore::CalibrationStore(const std::filesystem::path& dir)
    : folder_lock_(dir), db_(dir / kFileName, /*busy_timeout_ms=*/5000) {
  db_.Exec("PRAGMA journal_mode = WAL");
  db_.Exec("PRAGMA synchronous = FULL");
  db_.Exec("PRAGMA foreign_keys = ON");
  db_.Exec(kSchema);
}

CalibrationStore::~CalibrationStore() = default;

// ----------------------------------------------------------------------------------- samples

CalibrationStore::AddResult CalibrationStore::AddSamples(
    const std::string& set, const std::vector<calibration::EyeHandSample>& samples) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  Statement insert(db_,
                   "INSERT INTO samples (set_name, stamp_ns, xa, ya, za, xb, yb, zb, path) "
                   "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)");
  for (const auto& s : samples) {
    insert.Bind(1, set).Bind(2, s.stamp_ns);
    for (int i = 0; i < 3; ++i) insert.Bind(3 + i, s.xa(i)).Bind(6 + i, s.xb(i));
    insert.Bind(9, s.path).Run();
    insert.Reset();
  }
  Statement count(db_, "SELECT COUNT(*) FROM samples WHERE set_name = ?");
  count.Bind(1, set).Step();
  AddResult result{samples.size(), static_cast<uint64_t>(count.Int(0))};
  tx.Commit();
  return result;
}

std::vector<calibration::EyeHandSample> CalibrationStore::Samples(const std::string& set) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, set.empty() ? "SELECT stamp_ns, xa, ya, za, xb, yb, zb, path FROM samples "
                                 "ORDER BY id"
                               : "SELECT stamp_ns, xa, ya, za, xb, yb, zb, path FROM samples "
                                 "WHERE set_name = ? ORDER BY id");
  if (!set.empty()) s.Bind(1, set);
  std::vector<calibration::EyeHandSample> out;
  while (s.Step()) {
    calibration::EyeHandSample e;
    e.stamp_ns = s.Int(0);
    e.xa = Eigen::Vector3d(s.Real(1), s.Real(2), s.Real(3));
    e.xb = Eigen::Vector3d(s.Real(4), s.Real(5), s.Real(6));
    e.path = s.Text(7);
    out.push_back(std::move(e));
  }
  return out;
}

std::vector<CalibrationStore::SetInfo> CalibrationStore::SampleSets() const {
  std::lock_guard lock(mutex_);
  Statement s(db_,
              "SELECT set_name, COUNT(*), COUNT(DISTINCT path) FROM samples GROUP BY set_name "
              "ORDER BY set_name");
  std::vector<SetInfo> out;
  while (s.Step()) {
    out.push_back({s.Text(0), static_cast<uint64_t>(s.Int(1)), static_cast<uint32_t>(s.Int(2))});
  }
  return out;
}

uint64_t CalibrationStore::DeleteSamples(const std::string& set) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  Statement del(db_, "DELETE FROM samples WHERE set_name = ?");
  del.Bind(1, set).Run();
  const auto n = static_cast<uint64_t>(db_.changes());
  tx.Commit();
  return n;
}

// -------------------------------------------------------------------------------------- jobs

v1::Job CalibrationStore::CreateJob(v1::JobKind kind, const v1::JobSpec& spec,
                                    bool activate_on_success, int64_t now_ns) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  Statement next(db_, "SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs");
  next.Step();
  const int64_t seq = next.Int(0);
  v1::Job job;
  job.set_id("job-" + std::to_string(seq));
  job.set_kind(kind);
  *job.mutable_spec() = spec;
  job.set_state(v1::QUEUED);
  job.set_stage("queued");
  job.set_created_ns(now_ns);
  job.set_activate_on_success(activate_on_success);
  Statement insert(db_,
                   "INSERT INTO jobs (id, seq, kind, spec_json, activate_on_success, state, stage, "
                   "created_ns) VALUES (?, ?, ?, ?, ?, ?, ?, ?)");
  insert.Bind(1, job.id())
      .Bind(2, seq)
      .Bind(3, static_cast<int64_t>(kind))
      .Bind(4, ToJson(spec))
      .Bind(5, static_cast<int64_t>(activate_on_success))
      .Bind(6, static_cast<int64_t>(v1::QUEUED))
      .Bind(7, job.stage())
      .Bind(8, now_ns)
      .Run();
  tx.Commit();
  return job;
}

void CalibrationStore::UpdateJob(const v1::Job& job) {
  std::lock_guard lock(mutex_);
  WriteJobLocked(job);
}

// Every field of a stored job, written over its row; throws kNotFound for an unknown id.
void CalibrationStore::WriteJobLocked(const v1::Job& job) {
  Statement update(db_,
                   "UPDATE jobs SET state = ?, stage = ?, progress = ?, iteration = ?, cost = ?, "
                   "message = ?, model_id = ?, started_ns = ?, finished_ns = ?, errors_json = ? "
                   "WHERE id = ?");
  update.Bind(1, static_cast<int64_t>(job.state()))
      .Bind(2, job.stage())
      .Bind(3, job.progress())
      .Bind(4, static_cast<int64_t>(job.iteration()))
      .Bind(5, job.cost())
      .Bind(6, job.message())
      .Bind(7, job.model_id())
      .Bind(8, job.started_ns())
      .Bind(9, job.finished_ns())
      .Bind(10, ToJson(job.errors()))
      .Bind(11, job.id())
      .Run();
  if (db_.changes() == 0) throw StoreError(Code::kNotFound, "no job " + job.id());
}

std::optional<v1::Job> CalibrationStore::GetJob(const std::string& id) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, (std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?").c_str());
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  return ReadJob(s);
}

std::vector<v1::Job> CalibrationStore::ListJobs(uint32_t limit) const {
  std::lock_guard lock(mutex_);
  Statement s(
      db_, (std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY seq DESC LIMIT ?").c_str());
  s.Bind(1, static_cast<int64_t>(limit));
  std::vector<v1::Job> out;
  while (s.Step()) out.push_back(ReadJob(s));
  return out;
}

int CalibrationStore::InterruptUnfinishedJobs(int64_t now_ns) {
  std::lock_guard lock(mutex_);
  Statement s(db_,
              "UPDATE jobs SET state = ?, finished_ns = ?, "
              "message = 'the service stopped while the job was ' || "
              "CASE state WHEN ? THEN 'queued' ELSE 'running' END || "
              "' (epmapd crashed, was killed or shut down); start it again' "
              "WHERE state IN (?, ?)");
  s.Bind(1, static_cast<int64_t>(v1::INTERRUPTED))
      .Bind(2, now_ns)
      .Bind(3, static_cast<int64_t>(v1::QUEUED))
      .Bind(4, static_cast<int64_t>(v1::QUEUED))
      .Bind(5, static_cast<int64_t>(v1::RUNNING))
      .Run();
  return db_.changes();
}

// ------------------------------------------------------------------------------------ models

std::optional<std::string> CalibrationStore::ActiveModelId(v1::JobKind kind) const {
  Statement s(db_, "SELECT model_id FROM active_models WHERE kind = ?");
  s.Bind(1, static_cast<int64_t>(kind));
  if (!s.Step()) return std::nullopt;
  return s.Text(0);
}

void CalibrationStore::ActivateLocked(const std::string& id, v1::JobKind kind, int64_t now_ns) {
  Statement set(db_, "INSERT OR REPLACE INTO active_models (kind, model_id) VALUES (?, ?)");
  set.Bind(1, static_cast<int64_t>(kind)).Bind(2, id).Run();
  Statement history(
      db_, "INSERT INTO activation_history (kind, model_id, activated_ns) VALUES (?, ?, ?)");
  history.Bind(1, static_cast<int64_t>(kind)).Bind(2, id).Bind(3, now_ns).Run();
}

v1::Model CalibrationStore::FinishJobWithModel(v1::Job& job, v1::Model model, bool activate,
                                               int64_t now_ns) {
  std::lock_guard lock(mutex_);
  Transaction tx(db_);
  Statement next(db_, "SELECT COALESCE(MAX(version), 0) + 1 FROM models WHERE kind = ?");
  next.Bind(1, static_cast<int64_t>(model.kind())).Step();
  const auto version = static_cast<uint32_t>(next.Int(0));
  model.set_version(version);
  model.set_id(std::string(JobKindName(model.kind())) + "-" + std::to_string(version));
  model.set_job_id(job.id());
  model.set_created_ns(now_ns);
  Statement insert(db_,
                   "INSERT INTO models (id, kind, version, job_id, created_ns, errors_json, "
                   "description, parameters_json) VALUES (?, ?, ?, ?, ?, ?, ?, ?)");
  insert.Bind(1, model.id())
      .Bind(2, static_cast<int64_t>(model.kind()))
      .Bind(3, static_cast<int64_t>(version))
      .Bind(4, job.id())
      .Bind(5, now_ns)
      .Bind(6, ToJson(model.errors()))
      .Bind(7, model.description())
      .Bind(8, model.parameters_json())
      .Run();
  job.set_state(v1::SUCCEEDED);
  job.set_model_id(model.id());
  job.set_finished_ns(now_ns);
  job.set_progress(1.0);
  WriteJobLocked(job);
  if (activate) ActivateLocked(model.id(), model.kind(), now_ns);
  tx.Commit();
  model.set_active(activate);
  return model;
}

std::optional<v1::Model> CalibrationStore::GetModel(const std::string& id) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, (std::string("SELECT ") + kModelColumns + " FROM models WHERE id = ?").c_str());
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  v1::Model m = ReadModel(s);
  m.set_active(ActiveModelId(m.kind()) == m.id());
  return m;
}

std::vector<v1::Model> CalibrationStore::ListModels(v1::JobKind kind) const {
  std::lock_guard lock(mutex_);
  const bool all = kind == v1::JOB_KIND_UNSPECIFIED;
  Statement s(db_, (std::string("SELECT ") + kModelColumns + " FROM models " +
                    (all ? "" : "WHERE kind = ? ") + "ORDER BY kind, version")
                       .c_str());
  if (!all) s.Bind(1, static_cast<int64_t>(kind));
  std::set<std::string> active;
  for (const auto k : {v1::EYE_HAND, v1::STEREO_EXTRINSICS}) {
    if (auto id = ActiveModelId(k)) active.insert(*id);
  }
  std::vector<v1::Model> out;
  while (s.Step()) {
    out.push_back(ReadModel(s));
    out.back().set_active(active.count(out.back().id()) > 0);
  }
  return out;
}

std::optional<v1::Model> CalibrationStore::ActiveModel(v1::JobKind kind) const {
  std::optional<std::string> id;
  {
    std::lock_guard lock(mutex_);
    id = ActiveModelId(kind);
  }
  if (!id) return std::nullopt;
  return GetModel(*id);
}

v1::Model CalibrationStore::Activate(const std::string& id, int64_t now_ns) {
  {
    std::lock_guard lock(mutex_);
    Statement find(db_, "SELECT kind FROM models WHERE id = ?");
    find.Bind(1, id);
    if (!find.Step()) throw StoreError(Code::kNotFound, "no model '" + id + "'");
    const auto kind = static_cast<v1::JobKind>(find.Int(0));
    if (ActiveModelId(kind) != id) {
      Transaction tx(db_);
      ActivateLocked(id, kind, now_ns);
      tx.Commit();
    }
  }
  return *GetModel(id);
}

std::optional<v1::Model> CalibrationStore::Rollback(v1::JobKind kind, int64_t /*now_ns*/) {
  std::optional<std::string> restored;
  {
    std::lock_guard lock(mutex_);
    if (!ActiveModelId(kind)) {
      throw StoreError(Code::kFailedPrecondition, std::string("no ") + JobKindName(kind) +
                                                      " model is active: nothing to roll back");
    }
    Transaction tx(db_);
    // The newest activation is undone; the one before it (if any) tells what was active then.
    Statement newest(db_,
                     "SELECT seq FROM activation_history WHERE kind = ? ORDER BY seq DESC LIMIT 1");
    newest.Bind(1, static_cast<int64_t>(kind));
    if (newest.Step()) {
      Statement del(db_, "DELETE FROM activation_history WHERE seq = ?");
      del.Bind(1, newest.Int(0)).Run();
    }
    Statement previous(db_,
                       "SELECT model_id FROM activation_history WHERE kind = ? "
                       "ORDER BY seq DESC LIMIT 1");
    previous.Bind(1, static_cast<int64_t>(kind));
    if (previous.Step()) {
      restored = previous.Text(0);
      Statement set(db_, "INSERT OR REPLACE INTO active_models (kind, model_id) VALUES (?, ?)");
      set.Bind(1, static_cast<int64_t>(kind)).Bind(2, *restored).Run();
    } else {
      Statement clear(db_, "DELETE FROM active_models WHERE kind = ?");
      clear.Bind(1, static_cast<int64_t>(kind)).Run();
    }
    tx.Commit();
  }
  if (!restored) return std::nullopt;
  return GetModel(*restored);
}

}  // namespace epmap::mapping
