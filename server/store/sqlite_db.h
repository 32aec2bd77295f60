// RAII wrappers over the SQLite C API: a connection, a prepared statement and
// an immediate transaction. Every SQLite error becomes an absl::Status naming
// the operation, the SQL and sqlite3_errmsg(). Values always go through bound
// parameters; SQL text is never built from values.
//
// Threading: a SqliteDb and its Statements belong to one thread at a time
// (the owner serialises access, e.g. with a mutex). Several SqliteDb objects,
// in one or several processes, may open the same file: WAL lets readers run
// beside the single writer, and busy_timeout makes writers wait for each other.
#ifndef MVBRDF_SERVER_STORE_SQLITE_DB_H_
#define MVBRDF_SERVER_STORE_SQLITE_DB_H_

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

struct sqlite3;
struct sqlite3_stmt;

namespace mvbrdf::store {

// How long a writer waits for another connection's write transaction.
constexpr int kBusyTimeoutMs = 5000;

class SqliteDb {
 public:
  // Opens (creating when missing) the database file with journal_mode=WAL,
  // synchronous=NORMAL, foreign_keys=ON and a 5 s busy timeout. Applies no
  // schema (see schema.h).
  static absl::StatusOr<std::unique_ptr<SqliteDb>> Open(const std::filesystem::path& path);

  ~SqliteDb();
  SqliteDb(const SqliteDb&) = delete;
  SqliteDb& operator=(const SqliteDb&) = delete;

  // Runs SQL without parameters (schema, pragmas); `sql` may hold several
  // statements. Never pass values in it.
  absl::Status Exec(absl::string_view sql);

  // Rows changed by the last INSERT/UPDATE/DELETE on this connection.
  int64_t Changes() const;

  const std::filesystem::path& path() const { return path_; }
  sqlite3* handle() const { return db_; }

 private:
  SqliteDb(sqlite3* db, std::filesystem::path path) : db_(db), path_(std::move(path)) {}

  sqlite3* db_;
  std::filesystem::path path_;
};

// `code` (an SQLite result code) as a Status: "<operation> '<sql>': <errmsg>".
absl::Status SqliteError(sqlite3* db, int code, absl::string_view operation, absl::string_view sql);

enum class StepResult { kRow, kDone };

// A prepared statement. Parameter and column indices follow SQLite: bind
// indices start at 1, column indices at 0.
class Statement {
 public:
  static absl::StatusOr<Statement> Prepare(SqliteDb& db, absl::string_view sql);

  ~Statement();
  Statement(Statement&& other) noexcept;
  Statement& operator=(Statement&& other) noexcept;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  absl::Status BindInt64(int index, int64_t value);
  absl::Status BindDouble(int index, double value);
  absl::Status BindText(int index, absl::string_view value);  // copied by SQLite
  absl::Status BindBlob(int index, absl::string_view bytes);  // copied by SQLite
  // Not copied: `bytes` must stay alive and unchanged until the statement is
  // reset or finalized (large blobs, where a copy would double the memory).
  absl::Status BindBlobNoCopy(int index, absl::string_view bytes);
  absl::Status BindNull(int index);

  // One step: kRow when a row is available through the column getters.
  absl::StatusOr<StepResult> Step();
  // Steps through every row, calling `row` on each (it reads the columns);
  // stops at the first error, from SQLite or from `row`.
  absl::Status ForEachRow(const std::function<absl::Status()>& row);
  // Steps until done (for statements that return no rows).
  absl::Status Run();
  // Ready to step again with new bindings (bindings are cleared).
  absl::Status Reset();

  bool ColumnIsNull(int column) const;
  int64_t ColumnInt64(int column) const;
  double ColumnDouble(int column) const;
  std::string ColumnText(int column) const;
  std::string ColumnBlob(int column) const;

  const std::string& sql() const { return sql_; }

 private:
  Statement(sqlite3* db, sqlite3_stmt* stmt, std::string sql) : db_(db), stmt_(stmt), sql_(std::move(sql)) {}
  absl::Status CheckBind(int code, int index);

  sqlite3* db_ = nullptr;
  sqlite3_stmt* stmt_ = nullptr;
  std::string sql_;
};

// BEGIN IMMEDIATE on construction (takes the write lock up front, so a
// read-then-write transaction never fails half-way with SQLITE_BUSY); rolls
// back in the destructor unless Commit() succeeded.
class Transaction {
 public:
  static absl::StatusOr<Transaction> Begin(SqliteDb& db);

  ~Transaction();
  Transaction(Transaction&& other) noexcept;
  Transaction& operator=(Transaction&&) = delete;
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

  absl::Status Commit();

 private:
  explicit Transaction(SqliteDb* db) : db_(db) {}

  SqliteDb* db_;  // null once committed, rolled back or moved from
};

}  // namespace mvbrdf::store

#endif  // MVBRDF_SERVER_STORE_SQLITE_DB_H_
