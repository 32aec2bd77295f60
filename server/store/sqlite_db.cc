#include "server/store/sqlite_db.h"

#include <sqlite3.h>

#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"

namespace mvbrdf::store {
namespace {

absl::StatusCode CodeOf(int sqlite_code) {
  switch (sqlite_code & 0xff) {  // primary result code
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return absl::StatusCode::kUnavailable;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return absl::StatusCode::kDataLoss;
    case SQLITE_CONSTRAINT:
      return absl::StatusCode::kFailedPrecondition;
    case SQLITE_CANTOPEN:
    case SQLITE_PERM:
    case SQLITE_READONLY:
      return absl::StatusCode::kPermissionDenied;
    case SQLITE_FULL:
      return absl::StatusCode::kResourceExhausted;
    default:
      return absl::StatusCode::kInternal;
  }
}

}  // namespace

absl::Status SqliteError(sqlite3* db, int code, absl::string_view operation, absl::string_view sql) {
  const char* message = db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(code);
  return absl::Status(CodeOf(code), absl::StrCat("sqlite ", operation, " '", sql, "': ", message));
}

// --- SqliteDb ---------------------------------------------------------------

absl::StatusOr<std::unique_ptr<SqliteDb>> SqliteDb::Open(const std::filesystem::path& path) {
  sqlite3* raw = nullptr;
  const int flags = SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX;
  const int code = sqlite3_open_v2(path.c_str(), &raw, flags, nullptr);
  if (code != SQLITE_OK) {
    absl::Status status = SqliteError(raw, code, "open", path.string());
    sqlite3_close(raw);  // a handle is returned even on failure
    return status;
  }
  std::unique_ptr<SqliteDb> db(new SqliteDb(raw, path));
  sqlite3_extended_result_codes(raw, 1);
  if (const int busy = sqlite3_busy_timeout(raw, kBusyTimeoutMs); busy != SQLITE_OK) {
    return SqliteError(raw, busy, "busy_timeout", path.string());
  }
  // journal_mode returns a row naming the mode actually set: WAL is refused on
  // some file systems, and a silent fallback would lose concurrent readers.
  MVBRDF_ASSIGN_OR_RETURN(Statement journal, Statement::Prepare(*db, "PRAGMA journal_mode=WAL"));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, journal.Step());
  if (step != StepResult::kRow || journal.ColumnText(0) != "wal") {
    return absl::FailedPreconditionError(
        absl::StrCat(path.string(), ": cannot switch the database to WAL journal mode"));
  }
  MVBRDF_RETURN_IF_ERROR(db->Exec("PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=ON;"));
  return db;
}

SqliteDb::~SqliteDb() {
  // sqlite3_close_v2 defers the close until stray statements are finalised,
  // so a destructor order mistake cannot leak the connection.
  sqlite3_close_v2(db_);
}

absl::Status SqliteDb::Exec(absl::string_view sql) {
  const std::string text(sql);
  char* message = nullptr;
  const int code = sqlite3_exec(db_, text.c_str(), nullptr, nullptr, &message);
  sqlite3_free(message);  // the same text as sqlite3_errmsg
  if (code != SQLITE_OK) return SqliteError(db_, code, "exec", sql);
  return absl::OkStatus();
}

int64_t SqliteDb::Changes() const { return sqlite3_changes(db_); }

// --- Statement --------------------------------------------------------------

absl::StatusOr<Statement> Statement::Prepare(SqliteDb& db, absl::string_view sql) {
  sqlite3_stmt* stmt = nullptr;
  const int code = sqlite3_prepare_v2(db.handle(), sql.data(), static_cast<int>(sql.size()), &stmt, nullptr);
  if (code != SQLITE_OK) return SqliteError(db.handle(), code, "prepare", sql);
  if (stmt == nullptr) return absl::InvalidArgumentError(absl::StrCat("sqlite prepare '", sql, "': empty statement"));
  return Statement(db.handle(), stmt, std::string(sql));
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

Statement::Statement(Statement&& other) noexcept
    : db_(other.db_), stmt_(std::exchange(other.stmt_, nullptr)), sql_(std::move(other.sql_)) {}

Statement& Statement::operator=(Statement&& other) noexcept {
  if (this != &other) {
    sqlite3_finalize(stmt_);
    db_ = other.db_;
    stmt_ = std::exchange(other.stmt_, nullptr);
    sql_ = std::move(other.sql_);
  }
  return *this;
}

absl::Status Statement::CheckBind(int code, int index) {
  if (code == SQLITE_OK) return absl::OkStatus();
  return SqliteError(db_, code, absl::StrCat("bind of parameter ", index, " in"), sql_);
}

absl::Status Statement::BindInt64(int index, int64_t value) {
  return CheckBind(sqlite3_bind_int64(stmt_, index, value), index);
}

absl::Status Statement::BindDouble(int index, double value) {
  return CheckBind(sqlite3_bind_double(stmt_, index, value), index);
}

absl::Status Statement::BindText(int index, absl::string_view value) {
  return CheckBind(sqlite3_bind_text64(stmt_, index, value.data(), value.size(), SQLITE_TRANSIENT, SQLITE_UTF8),
                   index);
}

absl::Status Statement::BindBlob(int index, absl::string_view bytes) {
  // A null pointer would bind NULL, not an empty blob.
  static const char kEmpty = 0;
  const void* data = bytes.empty() ? &kEmpty : bytes.data();
  return CheckBind(sqlite3_bind_blob64(stmt_, index, data, bytes.size(), SQLITE_TRANSIENT), index);
}

absl::Status Statement::BindBlobNoCopy(int index, absl::string_view bytes) {
  static const char kEmpty = 0;
  const void* data = bytes.empty() ? &kEmpty : bytes.data();
  return CheckBind(sqlite3_bind_blob64(stmt_, index, data, bytes.size(), SQLITE_STATIC), index);
}

absl::Status Statement::BindNull(int index) { return CheckBind(sqlite3_bind_null(stmt_, index), index); }

absl::Status Statement::ForEachRow(const std::function<absl::Status()>& row) {
  while (true) {
    MVBRDF_ASSIGN_OR_RETURN(const StepResult step, Step());
    if (step == StepResult::kDone) return absl::OkStatus();
    MVBRDF_RETURN_IF_ERROR(row());
  }
}

absl::StatusOr<StepResult> Statement::Step() {
  const int code = sqlite3_step(stmt_);
  if (code == SQLITE_ROW) return StepResult::kRow;
  if (code == SQLITE_DONE) return StepResult::kDone;
  return SqliteError(db_, code, "step of", sql_);
}

absl::Status Statement::Run() {
  while (true) {
    MVBRDF_ASSIGN_OR_RETURN(StepResult step, Step());
    if (step == StepResult::kDone) return absl::OkStatus();
  }
}

absl::Status Statement::Reset() {
  // sqlite3_reset repeats the last step's error; that error was already
  // reported by Step(), so only clearing matters here.
  sqlite3_reset(stmt_);
  const int code = sqlite3_clear_bindings(stmt_);
  if (code != SQLITE_OK) return SqliteError(db_, code, "reset of", sql_);
  return absl::OkStatus();
}

bool Statement::ColumnIsNull(int column) const { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }

int64_t Statement::ColumnInt64(int column) const { return sqlite3_column_int64(stmt_, column); }

double Statement::ColumnDouble(int column) const { return sqlite3_column_double(stmt_, column); }

std::string Statement::ColumnText(int column) const {
  const unsigned char* text = sqlite3_column_text(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);  // after the pointer: the conversion may change it
  if (text == nullptr) return std::string();
  return std::string(reinterpret_cast<const char*>(text), static_cast<size_t>(size));
}

std::string Statement::ColumnBlob(int column) const {
  const void* data = sqlite3_column_blob(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  if (data == nullptr) return std::string();
  return std::string(static_cast<const char*>(data), static_cast<size_t>(size));
}

// --- Transaction ------------------------------------------------------------

absl::StatusOr<Transaction> Transaction::Begin(SqliteDb& db) {
  MVBRDF_RETURN_IF_ERROR(db.Exec("BEGIN IMMEDIATE"));
  return Transaction(&db);
}

Transaction::~Transaction() {
  if (db_ != nullptr) {
    // Nothing to report to: the caller is already returning an error, and
    // a failed ROLLBACK leaves SQLite rolling back on its own.
    (void)db_->Exec("ROLLBACK");
  }
}

Transaction::Transaction(Transaction&& other) noexcept : db_(std::exchange(other.db_, nullptr)) {}

absl::Status Transaction::Commit() {
  if (db_ == nullptr) return absl::FailedPreconditionError("sqlite COMMIT: transaction is no longer open");
  MVBRDF_RETURN_IF_ERROR(db_->Exec("COMMIT"));
  db_ = nullptr;
  return absl::OkStatus();
}

}  // namespace mvbrdf::store
