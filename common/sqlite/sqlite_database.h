#pragma once
// A thin RAII layer over SQLite for the service's durable state (the calibration store, the maps
// store): one connection, prepared statements finalised on scope exit, transactions rolled back
// when a scope is left by an exception. Every failure throws sqlite::Error whose message names
// the database file and what was being done, so callers only add what their data means.
// Not thread-safe by itself: each store guards its connection with its own mutex.

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

struct sqlite3;
struct sqlite3_stmt;

namespace epmap::sqlite {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Database {
 public:
  // Opens (creating) the file, read-write, waiting up to busy_timeout_ms for another
  // connection's lock. Throws Error (e.g. "file is not a database" shows on the first Exec).
  explicit Database(const std::filesystem::path& path, int busy_timeout_ms = 2000);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  // Runs one or more statements without results (schema, pragmas, plain DELETEs).
  void Exec(const char* sql);

  // Rows the last INSERT, UPDATE or DELETE changed.
  int changes() const;
  sqlite3* handle() const { return db_; }
  const std::filesystem::path& path() const { return path_; }
  // "<path>: <what>: <SQLite's message for the last failure>".
  std::string Describe(std::string_view what) const;

 private:
  std::filesystem::path path_;
  sqlite3* db_ = nullptr;
};

// One prepared statement. Bind* take 1-based parameter indices; column getters 0-based.
class Statement {
 public:
  Statement(const Database& db, const char* sql);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& Bind(int i, int64_t v);
  Statement& Bind(int i, double v);
  Statement& Bind(int i, const std::string& text);  // copied
  // The bytes must outlive the statement's next Step.
  Statement& BindBlob(int i, std::string_view bytes);
  // True while a row is available; false when done.
  bool Step();
  // Steps to the end (statements without results).
  void Run();
  // For running the statement again with new bindings.
  void Reset();

  int64_t Int(int col) const;
  double Real(int col) const;
  std::string Text(int col) const;
  std::string Blob(int col) const;

 private:
  void Check(int rc, const char* what);
  const Database& db_;
  sqlite3_stmt* stmt_ = nullptr;
};

// BEGIN IMMEDIATE on construction; Commit() or, on leaving the scope without it, ROLLBACK.
class Transaction {
 public:
  explicit Transaction(Database& db);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void Commit();

 private:
  Database& db_;
  bool done_ = false;
};

}  // namespace epmap::sqlite
