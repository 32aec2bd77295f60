// The storage schema and its migrations. PRAGMA user_version holds the version
// applied; each migration moves it up by one inside one transaction, so a
// crash leaves the database at the old or the new version, never between.
//
// Version 1:
//   jobs(id, client, state, scene_hash, request, error, created_ms, updated_ms)
//   tasks(id, job_id -> jobs, kind, key, depends_on -> tasks, state, attempts,
//         max_attempts, lease_owner, lease_expires_ms, result, error,
//         created_ms, updated_ms)
//   sample_cache(sequence_hash, configuration, sample_level, options_hash,
//                data (zlib), raw_size, stored_size, sha256 (of the raw
//                bytes), created_ms, last_used_ms)
//   artifacts(job_id, name, sha256, size, created_ms)
// Version 2 (a job's tasks form a graph):
//   task_deps(task_id -> tasks, depends_on -> tasks), one row per dependency,
//     in the order given; the rows of tasks.depends_on move here and the
//     column stays NULL from then on
//   tasks.added_by -> tasks: the task whose completion added this one
//   jobs.sealed (0/1): the server has added every task it will add; only a
//     sealed job succeeds. Version 1 jobs with tasks (or past queued) are
//     sealed by the migration, which keeps their version 1 meaning.
// Version 3 (task timing and the Sample cache in reports):
//   tasks.started_ms: when the current (or last) lease was handed out, 0
//     before the first lease (and for tasks leased by a version 2 server)
//   tasks.samples_from_cache (0/1): the task ran on (or, for gather, was
//     answered from) Samples the Sample cache already held
// Version 4 (a worker's own failures, issue #19):
//   tasks.worker_faults: failures a worker reported as its own environment's
//     (its disk, memory, EGL), which went back to the queue without using an
//     attempt; bounded by twice max_attempts
// Version 5 (what `watch` and `jobs` show, issue #20):
//   workers(id, name, registered_ms): every worker that registered, so a task's
//     lease_owner (a worker id) is shown with the worker's --name, also after
//     the worker or the server went away
//   tasks.stage_finished: the worker's StageFinished for the task (serialized
//     mvbrdf.v1.StageFinished, opaque here: seconds and metrics), NULL before;
//     a watch replays it, so each finished task is one event with its numbers
// Version 6 (issue #17):
//   sample_cache_pins(job_id, sequence_hash, configuration, sample_level,
//     options_hash): a Sample-cache entry a job uses; while the job is queued
//     or running the cache does not evict the entry (SampleCache::Pin)
// Times are unix milliseconds.
#ifndef MVBRDF_SERVER_STORE_SCHEMA_H_
#define MVBRDF_SERVER_STORE_SCHEMA_H_

#include <filesystem>
#include <memory>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/store/sqlite_db.h"

namespace mvbrdf::store {

// The newest schema this build knows.
constexpr int kSchemaVersion = 6;

// Brings the database up to kSchemaVersion. FAILED_PRECONDITION when the file
// was written by a newer build (its version is above kSchemaVersion).
absl::Status ApplyMigrations(SqliteDb& db);
// Brings the database up to `target_version` only (tests build old files
// with it). A database already past it is left alone.
absl::Status ApplyMigrationsUpTo(SqliteDb& db, int target_version);

// The version recorded in the file (0 for a new file).
absl::StatusOr<int> SchemaVersion(SqliteDb& db);

// SqliteDb::Open followed by ApplyMigrations: how every store opens its file.
absl::StatusOr<std::unique_ptr<SqliteDb>> OpenStoreDb(const std::filesystem::path& path);

}  // namespace mvbrdf::store

#endif  // MVBRDF_SERVER_STORE_SCHEMA_H_
