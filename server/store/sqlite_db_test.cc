#include "server/store/sqlite_db.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "server/store/schema.h"
#include "server/store/test_dir.h"

namespace mvbrdf::store {
namespace {

std::string QueryText(SqliteDb& db, const char* sql) {
  absl::StatusOr<Statement> statement = Statement::Prepare(db, sql);
  EXPECT_TRUE(statement.ok()) << statement.status();
  if (!statement.ok()) return "";
  absl::StatusOr<StepResult> step = statement->Step();
  EXPECT_TRUE(step.ok()) << step.status();
  if (!step.ok() || *step != StepResult::kRow) return "";
  return statement->ColumnText(0);
}

TEST(SqliteDbTest, OpenSetsPragmas) {
  TestDir dir;
  absl::StatusOr<std::unique_ptr<SqliteDb>> db = SqliteDb::Open(dir.db());
  ASSERT_TRUE(db.ok()) << db.status();
  EXPECT_EQ(QueryText(**db, "PRAGMA journal_mode"), "wal");
  EXPECT_EQ(QueryText(**db, "PRAGMA synchronous"), "1");  // NORMAL
  EXPECT_EQ(QueryText(**db, "PRAGMA foreign_keys"), "1");
  EXPECT_EQ(QueryText(**db, "PRAGMA busy_timeout"), "5000");
}

TEST(SqliteDbTest, BindAndReadEveryType) {
  TestDir dir;
  auto db = SqliteDb::Open(dir.db());
  ASSERT_TRUE(db.ok()) << db.status();
  ASSERT_TRUE((*db)->Exec("CREATE TABLE t (i INTEGER, d REAL, s TEXT, b BLOB, n TEXT)").ok());
  auto insert = Statement::Prepare(**db, "INSERT INTO t VALUES (?1, ?2, ?3, ?4, ?5)");
  ASSERT_TRUE(insert.ok()) << insert.status();
  const std::string blob("a\0b\xff", 4);
  ASSERT_TRUE(insert->BindInt64(1, int64_t{1} << 40).ok());
  ASSERT_TRUE(insert->BindDouble(2, 0.25).ok());
  ASSERT_TRUE(insert->BindText(3, "it's; DROP TABLE t; --").ok());
  ASSERT_TRUE(insert->BindBlob(4, blob).ok());
  ASSERT_TRUE(insert->BindNull(5).ok());
  ASSERT_TRUE(insert->Run().ok());

  auto select = Statement::Prepare(**db, "SELECT i, d, s, b, n FROM t");
  ASSERT_TRUE(select.ok());
  auto step = select->Step();
  ASSERT_TRUE(step.ok());
  ASSERT_EQ(*step, StepResult::kRow);
  EXPECT_EQ(select->ColumnInt64(0), int64_t{1} << 40);
  EXPECT_EQ(select->ColumnDouble(1), 0.25);
  EXPECT_EQ(select->ColumnText(2), "it's; DROP TABLE t; --");
  EXPECT_EQ(select->ColumnBlob(3), blob);
  EXPECT_TRUE(select->ColumnIsNull(4));
  step = select->Step();
  ASSERT_TRUE(step.ok());
  EXPECT_EQ(*step, StepResult::kDone);
}

TEST(SqliteDbTest, ErrorsNameTheOperationAndMessage) {
  TestDir dir;
  auto db = SqliteDb::Open(dir.db());
  ASSERT_TRUE(db.ok());
  auto bad = Statement::Prepare(**db, "SELEC 1");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("prepare 'SELEC 1'"), absl::string_view::npos) << bad.status();
  EXPECT_NE(bad.status().message().find("syntax error"), absl::string_view::npos) << bad.status();

  ASSERT_TRUE((*db)->Exec("CREATE TABLE u (x INTEGER PRIMARY KEY)").ok());
  ASSERT_TRUE((*db)->Exec("INSERT INTO u VALUES (1)").ok());
  auto duplicate = Statement::Prepare(**db, "INSERT INTO u VALUES (?1)");
  ASSERT_TRUE(duplicate.ok());
  ASSERT_TRUE(duplicate->BindInt64(1, 1).ok());
  absl::Status status = duplicate->Run();
  EXPECT_EQ(status.code(), absl::StatusCode::kFailedPrecondition) << status;
  EXPECT_NE(status.message().find("UNIQUE constraint failed"), absl::string_view::npos) << status;
}

TEST(SqliteDbTest, TransactionRollsBackUnlessCommitted) {
  TestDir dir;
  auto db = SqliteDb::Open(dir.db());
  ASSERT_TRUE(db.ok());
  ASSERT_TRUE((*db)->Exec("CREATE TABLE t (x INTEGER)").ok());
  {
    auto transaction = Transaction::Begin(**db);
    ASSERT_TRUE(transaction.ok());
    ASSERT_TRUE((*db)->Exec("INSERT INTO t VALUES (1)").ok());
  }  // rolled back
  EXPECT_EQ(QueryText(**db, "SELECT COUNT(*) FROM t"), "0");
  {
    auto transaction = Transaction::Begin(**db);
    ASSERT_TRUE(transaction.ok());
    ASSERT_TRUE((*db)->Exec("INSERT INTO t VALUES (2)").ok());
    ASSERT_TRUE(transaction->Commit().ok());
  }
  EXPECT_EQ(QueryText(**db, "SELECT COUNT(*) FROM t"), "1");
}

TEST(SchemaTest, CreatesVersionOneAndReopens) {
  TestDir dir;
  {
    auto db = OpenStoreDb(dir.db());
    ASSERT_TRUE(db.ok()) << db.status();
    auto version = SchemaVersion(**db);
    ASSERT_TRUE(version.ok());
    EXPECT_EQ(*version, kSchemaVersion);
    for (const char* table : {"jobs", "tasks", "sample_cache", "artifacts"}) {
      auto statement = Statement::Prepare(**db, "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name = ?1");
      ASSERT_TRUE(statement.ok());
      ASSERT_TRUE(statement->BindText(1, table).ok());
      ASSERT_TRUE(statement->Step().ok());
      EXPECT_EQ(statement->ColumnInt64(0), 1) << table;
    }
  }
  auto again = OpenStoreDb(dir.db());  // migrations are not re-applied
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(QueryText(**again, "PRAGMA integrity_check"), "ok");
}

TEST(SchemaTest, NewerVersionIsRefused) {
  TestDir dir;
  {
    auto db = OpenStoreDb(dir.db());
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE((*db)->Exec("PRAGMA user_version = 99").ok());
  }
  auto db = OpenStoreDb(dir.db());
  ASSERT_FALSE(db.ok());
  EXPECT_EQ(db.status().code(), absl::StatusCode::kFailedPrecondition) << db.status();
  EXPECT_NE(db.status().message().find("99"), absl::string_view::npos) << db.status();
}

}  // namespace
}  // namespace mvbrdf::store
