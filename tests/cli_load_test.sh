#!/usr/bin/env bash
# A small load on loopback (issue #7): 12 jobs from 4 clients at once on one
# `mvbrdf server` with 2 `mvbrdf worker` processes; every job must succeed,
# each client must list exactly its own jobs, the database must pass
# PRAGMA integrity_check and the server's peak RSS must stay under MAX_MIB
# (512 by default; tests/CMakeLists.txt widens it for the ASan build).
# The full-size figures (50 jobs from 10 clients) come from scripts/bench-load.
# Usage: cli_load_test.sh MVBRDF_BINARY WORK_DIR [MAX_MIB]
set -u
exec /usr/bin/python3 "$(dirname "$0")/load_driver.py" --bin "$1" --work "$2" --jobs 12 --clients 4 --workers 2 \
  --max-server-mib "${3:-512}"
