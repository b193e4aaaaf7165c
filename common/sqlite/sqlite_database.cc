#include "common/sqlite/sqlite_database.h"

#include <sqlite3.h>

namespace epmap::sqlite {

Database::Database(const std::filesystem::path& path, int busy_timeout_ms) : path_(path) {
  if (sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) !=
      SQLITE_OK) {
    const std::string message = db_ ? Describe("cannot open") : path_.string() + ": out of memory";
    sqlite3_close(db_);
    throw Error(message);
  }
  sqlite3_busy_timeout(db_, busy_timeout_ms);
}

Database::~Database() {
  sqlite3_close(db_);
}

void Database::Exec(const char* sql) {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = path_.string() + ": " + (error ? error : "unknown error");
    sqlite3_free(error);
    throw Error(message);
  }
}

int Database::changes() const {
  return sqlite3_changes(db_);
}

std::string Database::Describe(std::string_view what) const {
  return path_.string() + ": " + std::string(what) + ": " + sqlite3_errmsg(db_);
}

Statement::Statement(const Database& db, const char* sql) : db_(db) {
  if (sqlite3_prepare_v2(db.handle(), sql, -1, &stmt_, nullptr) != SQLITE_OK) {
    throw Error(db.Describe("cannot prepare"));
  }
}

Statement::~Statement() {
  sqlite3_finalize(stmt_);
}

void Statement::Check(int rc, const char* what) {
  if (rc != SQLITE_OK) throw Error(db_.Describe(what));
}

Statement& Statement::Bind(int i, int64_t v) {
  Check(sqlite3_bind_int64(stmt_, i, v), "bind");
  return *this;
}

Statement& Statement::Bind(int i, double v) {
  Check(sqlite3_bind_double(stmt_, i, v), "bind");
  return *this;
}

Statement& Statement::Bind(int i, const std::string& text) {
  Check(sqlite3_bind_text64(stmt_, i, text.data(), text.size(), SQLITE_TRANSIENT, SQLITE_UTF8),
        "bind");
  return *this;
}

Statement& Statement::BindBlob(int i, std::string_view bytes) {
  Check(sqlite3_bind_blob64(stmt_, i, bytes.data(), bytes.size(), SQLITE_STATIC), "bind");
  return *this;
}

bool Statement::Step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  throw Error(db_.Describe("step"));
}

void Statement::Run() {
  while (Step()) {
  }
}

void Statement::Reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

int64_t Statement::Int(int col) const {
  return sqlite3_column_int64(stmt_, col);
}

double Statement::Real(int col) const {
  return sqlite3_column_double(stmt_, col);
}

std::string Statement::Text(int col) const {
  const auto* p = sqlite3_column_text(stmt_, col);
  return p ? std::string(reinterpret_cast<const char*>(p),
                         static_cast<size_t>(sqlite3_column_bytes(stmt_, col)))
           : std::string();
}

std::string Statement::Blob(int col) const {
  const auto* p = static_cast<const char*>(sqlite3_column_blob(stmt_, col));
  return p ? std::string(p, static_cast<size_t>(sqlite3_column_bytes(stmt_, col))) : std::string();
}

Transaction::Transaction(Database& db) : db_(db) {
  db_.Exec("BEGIN IMMEDIATE");
}

Transaction::~Transaction() {
  if (!done_) sqlite3_exec(db_.handle(), "ROLLBACK", nullptr, nullptr, nullptr);
}

void Transaction::Commit() {
  db_.Exec("COMMIT");
  done_ = true;
}

}  // namespace epmap::sqlite
