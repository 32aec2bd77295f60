#!/usr/bin/env python3
"""The write rate of the server's SQLite file (docs/deploy.md "Capacity"): commits/s of transactions shaped like
JobStore's, on a copy of a real state.db (the server's schema), with the server's PRAGMAs (journal_mode=WAL,
synchronous=NORMAL, foreign_keys=ON; server/store/sqlite_db.cc), through the same libsqlite3.

  lease:  one task row updated (lease a task, renew a lease, finish a task: one UPDATE each)
  event:  one task row updated and one artifact row inserted (a worker's output indexed)
  submit: one job row and 12 task rows inserted (a job with a gather, 8 sweeps, choose, reflectance, ...)

Usage: deploy/bench/sqlite_writes.py STATE_DB [N]   (STATE_DB is copied, never written; prints JSON)"""

import json
import os
import shutil
import sqlite3
import sys
import tempfile
import time

source, n = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 3000
work = tempfile.mkdtemp(dir=os.path.dirname(os.path.abspath(source)))  # the same file system as the server's
db_path = os.path.join(work, "state.db")
src = sqlite3.connect(source)
dst = sqlite3.connect(db_path)
src.backup(dst)  # the online backup API: what `sqlite3 state.db ".backup ..."` uses
src.close()
dst.close()
db = sqlite3.connect(db_path, isolation_level=None)
assert db.execute("PRAGMA journal_mode=WAL").fetchone()[0] == "wal"
db.execute("PRAGMA synchronous=NORMAL")
db.execute("PRAGMA foreign_keys=ON")


def columns(table):
    return [r[1] for r in db.execute(f"PRAGMA table_info({table})")]


def clone(table, key, old, new):
    """INSERT a copy of row `old` of `table` under key `new`."""
    cols = columns(table)
    select = ", ".join("?" if c == key else c for c in cols)
    db.execute(f"INSERT INTO {table} ({', '.join(cols)}) SELECT {select} FROM {table} WHERE {key} = ?", (new, old))


job = db.execute("SELECT id FROM jobs LIMIT 1").fetchone()[0]
tasks = [r[0] for r in db.execute("SELECT id FROM tasks WHERE job_id = ? AND depends_on IS NULL", (job,))]
artifact = db.execute("SELECT rowid, * FROM artifacts LIMIT 1").fetchone()
artifact_cols = columns("artifacts")


def run(name, body, count):
    t0 = time.perf_counter()
    for i in range(count):
        db.execute("BEGIN IMMEDIATE")
        body(i)
        db.execute("COMMIT")
    seconds = time.perf_counter() - t0
    return {"transactions": count, "seconds": round(seconds, 3), "per_second": round(count / seconds, 1)}


def lease(i):
    db.execute("UPDATE tasks SET state = 'leased', lease_owner = ?, lease_expires_ms = ?, attempts = attempts + 1, "
               "updated_ms = ? WHERE id = ?", (f"w{i % 8}", i + 30000, i, tasks[i % len(tasks)]))


def event(i):
    lease(i)
    values = [f"bench-{i}" if isinstance(v, str) and c in ("path", "name") else v
              for c, v in zip(artifact_cols, artifact[1:])]
    db.execute(f"INSERT OR REPLACE INTO artifacts ({', '.join(artifact_cols)}) VALUES "
               f"({', '.join('?' * len(artifact_cols))})", values)


def submit(i):
    new_job = f"benchjob{i:08d}"
    clone("jobs", "id", job, new_job)
    for k in range(12):
        cols = columns("tasks")
        select = ", ".join({"id": "?", "job_id": "?", "depends_on": "NULL", "added_by": "NULL"}.get(c, c) for c in cols)
        db.execute(f"INSERT INTO tasks ({', '.join(cols)}) SELECT {select} FROM tasks WHERE id = ?",
                   (f"{new_job}-{k}", new_job, tasks[0]))


result = {"sqlite": sqlite3.sqlite_version, "pragmas": "journal_mode=WAL synchronous=NORMAL foreign_keys=ON",
          "lease": run("lease", lease, n), "event": run("event", event, n), "submit": run("submit", submit, n // 10)}
db.close()
shutil.rmtree(work)
print(json.dumps(result, indent=2))
