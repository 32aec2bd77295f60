#include "server/store/schema.h"

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"

namespace mvbrdf::store {
namespace {

// kMigrations[i] takes the schema from version i to version i + 1.
constexpr const char* kMigrations[] = {
    // 0 -> 1
    R"sql(
CREATE TABLE jobs (
  id          TEXT PRIMARY KEY,
  client      TEXT NOT NULL,
  state       TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  scene_hash  TEXT NOT NULL,
  request     BLOB NOT NULL,
  error       TEXT NOT NULL DEFAULT '',
  created_ms  INTEGER NOT NULL,
  updated_ms  INTEGER NOT NULL
);
CREATE INDEX jobs_by_client ON jobs (client, created_ms);
CREATE INDEX jobs_by_state ON jobs (state);

CREATE TABLE tasks (
  id                TEXT PRIMARY KEY,
  job_id            TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
  kind              TEXT NOT NULL,
  key               TEXT NOT NULL,
  depends_on        TEXT REFERENCES tasks (id),
  state             TEXT NOT NULL CHECK (state IN ('queued', 'leased', 'done', 'failed', 'cancelled')),
  attempts          INTEGER NOT NULL DEFAULT 0,
  max_attempts      INTEGER NOT NULL CHECK (max_attempts >= 1),
  lease_owner       TEXT,
  lease_expires_ms  INTEGER,
  result            BLOB,
  error             TEXT NOT NULL DEFAULT '',
  created_ms        INTEGER NOT NULL,
  updated_ms        INTEGER NOT NULL
);
CREATE INDEX tasks_by_job ON tasks (job_id);
CREATE INDEX tasks_by_state ON tasks (state, created_ms);
CREATE INDEX tasks_by_depends_on ON tasks (depends_on);

CREATE TABLE sample_cache (
  sequence_hash  TEXT NOT NULL,
  configuration  TEXT NOT NULL,
  sample_level   INTEGER NOT NULL,
  options_hash   TEXT NOT NULL,
  data           BLOB NOT NULL,
  raw_size       INTEGER NOT NULL,
  stored_size    INTEGER NOT NULL,
  sha256         TEXT NOT NULL,
  created_ms     INTEGER NOT NULL,
  last_used_ms   INTEGER NOT NULL,
  PRIMARY KEY (sequence_hash, configuration, sample_level, options_hash)
);
CREATE INDEX sample_cache_by_last_used ON sample_cache (last_used_ms);

CREATE TABLE artifacts (
  job_id      TEXT NOT NULL,
  name        TEXT NOT NULL,
  sha256      TEXT NOT NULL,
  size        INTEGER NOT NULL,
  created_ms  INTEGER NOT NULL,
  PRIMARY KEY (job_id, name)
);
CREATE INDEX artifacts_by_sha256 ON artifacts (sha256);
)sql",
    // 1 -> 2: many dependencies per task, sealed jobs, follow-up tasks.
    R"sql(
CREATE TABLE task_deps (
  task_id     TEXT NOT NULL REFERENCES tasks (id) ON DELETE CASCADE,
  depends_on  TEXT NOT NULL REFERENCES tasks (id) ON DELETE CASCADE,
  UNIQUE (task_id, depends_on)
);
CREATE INDEX task_deps_by_depends_on ON task_deps (depends_on);
INSERT INTO task_deps (task_id, depends_on)
  SELECT id, depends_on FROM tasks WHERE depends_on IS NOT NULL ORDER BY created_ms, rowid;
UPDATE tasks SET depends_on = NULL;

ALTER TABLE tasks ADD COLUMN added_by TEXT REFERENCES tasks (id);
CREATE INDEX tasks_by_added_by ON tasks (added_by);

ALTER TABLE jobs ADD COLUMN sealed INTEGER NOT NULL DEFAULT 0 CHECK (sealed IN (0, 1));
-- A version 1 job succeeded once its tasks were done: its graph was complete
-- as far as the store knew, so it is sealed. Only a job without tasks yet is
-- left open (its server was about to add them).
UPDATE jobs SET sealed = 1
  WHERE state <> 'queued' OR EXISTS (SELECT 1 FROM tasks WHERE tasks.job_id = jobs.id);
)sql",
    // 2 -> 3: when a lease began; whether a task's Samples came from the cache.
    R"sql(
ALTER TABLE tasks ADD COLUMN started_ms INTEGER NOT NULL DEFAULT 0;
ALTER TABLE tasks ADD COLUMN samples_from_cache INTEGER NOT NULL DEFAULT 0 CHECK (samples_from_cache IN (0, 1));
)sql",
    // 3 -> 4: failures of a worker's own environment, apart from attempts.
    R"sql(
ALTER TABLE tasks ADD COLUMN worker_faults INTEGER NOT NULL DEFAULT 0 CHECK (worker_faults >= 0);
)sql",
    // 4 -> 5: worker names; the worker's report of each finished task.
    R"sql(
CREATE TABLE workers (
  id             TEXT PRIMARY KEY,
  name           TEXT NOT NULL,
  registered_ms  INTEGER NOT NULL
);
ALTER TABLE tasks ADD COLUMN stage_finished BLOB;
)sql",
    // 5 -> 6: Sample-cache entries pinned by the jobs that use them.
    R"sql(
CREATE TABLE sample_cache_pins (
  job_id         TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
  sequence_hash  TEXT NOT NULL,
  configuration  TEXT NOT NULL,
  sample_level   INTEGER NOT NULL,
  options_hash   TEXT NOT NULL,
  PRIMARY KEY (job_id, sequence_hash, configuration, sample_level, options_hash)
);
CREATE INDEX sample_cache_pins_by_key ON sample_cache_pins (sequence_hash, configuration, sample_level, options_hash);
)sql",
};
static_assert(sizeof(kMigrations) / sizeof(kMigrations[0]) == kSchemaVersion,
              "one migration per schema version");

}  // namespace

absl::StatusOr<int> SchemaVersion(SqliteDb& db) {
  MVBRDF_ASSIGN_OR_RETURN(Statement query, Statement::Prepare(db, "PRAGMA user_version"));
  MVBRDF_ASSIGN_OR_RETURN(StepResult step, query.Step());
  if (step != StepResult::kRow) return absl::InternalError("PRAGMA user_version returned no row");
  return static_cast<int>(query.ColumnInt64(0));
}

absl::Status ApplyMigrations(SqliteDb& db) { return ApplyMigrationsUpTo(db, kSchemaVersion); }

absl::Status ApplyMigrationsUpTo(SqliteDb& db, int target_version) {
  if (target_version < 0 || target_version > kSchemaVersion) {
    return absl::InvalidArgumentError(
        absl::StrCat("ApplyMigrationsUpTo: target version ", target_version, " is not in [0, ", kSchemaVersion, "]"));
  }
  // Inside the write lock, so two processes opening a new file at once
  // cannot both create the tables.
  MVBRDF_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(db));
  MVBRDF_ASSIGN_OR_RETURN(int version, SchemaVersion(db));
  if (version > kSchemaVersion) {
    return absl::FailedPreconditionError(absl::StrCat(db.path().string(), ": schema version ", version,
                                                      " is newer than this build knows (", kSchemaVersion,
                                                      "); use a newer mvbrdf"));
  }
  if (version < 0) {
    return absl::DataLossError(absl::StrCat(db.path().string(), ": invalid schema version ", version));
  }
  for (int v = version; v < target_version; ++v) {
    MVBRDF_RETURN_IF_ERROR(db.Exec(kMigrations[v]));
    // PRAGMA takes no bound parameters; the value is our own integer.
    MVBRDF_RETURN_IF_ERROR(db.Exec(absl::StrCat("PRAGMA user_version = ", v + 1)));
  }
  return transaction.Commit();
}

absl::StatusOr<std::unique_ptr<SqliteDb>> OpenStoreDb(const std::filesystem::path& path) {
  MVBRDF_ASSIGN_OR_RETURN(std::unique_ptr<SqliteDb> db, SqliteDb::Open(path));
  MVBRDF_RETURN_IF_ERROR(ApplyMigrations(*db));
  return db;
}

}  // namespace mvbrdf::store
