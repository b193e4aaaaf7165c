// common/sqlite: the RAII layer both durable stores use, on real database files.

#include "common/sqlite/sqlite_database.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "tests/support/test_env.h"

namespace epmap::sqlite {
namespace {

TEST(SqliteDatabase, ValuesComeBackAsWritten) {
  const auto dir = testing::FreshTempDir("sqlite-values");
  const std::string blob("a\0b\xff", 4);  // bytes, not text: the NUL stays
  {
    Database db(dir / "t.sqlite3");
    db.Exec("CREATE TABLE t (i INTEGER, r REAL, s TEXT, b BLOB)");
    Statement insert(db, "INSERT INTO t VALUES (?, ?, ?, ?)");
    insert.Bind(1, int64_t{-1} << 40).Bind(2, 0.125).Bind(3, std::string("wall")).BindBlob(4, blob);
    insert.Run();
    EXPECT_EQ(db.changes(), 1);
    insert.Reset();
    insert.Bind(1, int64_t{7}).Run();  // the rest NULL after Reset
  }
  Database db(dir / "t.sqlite3");  // reopened: it was on disk
  Statement s(db, "SELECT i, r, s, b FROM t ORDER BY rowid");
  ASSERT_TRUE(s.Step());
  EXPECT_EQ(s.Int(0), int64_t{-1} << 40);
  EXPECT_EQ(s.Real(1), 0.125);
  EXPECT_EQ(s.Text(2), "wall");
  EXPECT_EQ(s.Blob(3), blob);
  ASSERT_TRUE(s.Step());
  EXPECT_EQ(s.Int(0), 7);
  EXPECT_EQ(s.Text(2), "");
  EXPECT_EQ(s.Blob(3), "");
  EXPECT_FALSE(s.Step());
}

TEST(SqliteDatabase, ATransactionLeftByAnExceptionIsRolledBack) {
  const auto dir = testing::FreshTempDir("sqlite-tx");
  Database db(dir / "t.sqlite3");
  db.Exec("CREATE TABLE t (i INTEGER)");
  {
    Transaction tx(db);
    Statement(db, "INSERT INTO t VALUES (1)").Run();
    tx.Commit();
  }
  EXPECT_THROW(
      {
        Transaction tx(db);
        Statement(db, "INSERT INTO t VALUES (2)").Run();
        throw std::runtime_error("the caller fails half-way");
      },
      std::runtime_error);
  Statement count(db, "SELECT COUNT(*), MAX(i) FROM t");
  ASSERT_TRUE(count.Step());
  EXPECT_EQ(count.Int(0), 1);
  EXPECT_EQ(count.Int(1), 1);
}

TEST(SqliteDatabase, FailuresSayWhichFileAndWhy) {
  const auto dir = testing::FreshTempDir("sqlite-errors");
  const auto junk = dir / "junk.sqlite3";
  std::ofstream(junk) << std::string(5000, 'x');
  Database db(junk);  // SQLite reads the header lazily
  try {
    db.Exec("CREATE TABLE t (i INTEGER)");
    FAIL() << "a file that is not a database was written to";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(junk.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a database"), std::string::npos) << e.what();
  }
  Database good(dir / "good.sqlite3");
  try {
    Statement s(good, "SELECT * FROM no_such_table");
    FAIL() << "a statement on a missing table was prepared";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_table"), std::string::npos) << e.what();
  }
  good.Exec("CREATE TABLE u (i INTEGER PRIMARY KEY)");
  Statement(good, "INSERT INTO u VALUES (1)").Run();
  EXPECT_THROW(Statement(good, "INSERT INTO u VALUES (1)").Run(), Error);  // constraint
  EXPECT_THROW(Database(dir / "missing-folder" / "x.sqlite3"), Error);
}

}  // namespace
}  // namespace epmap::sqlite
