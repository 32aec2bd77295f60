#!/usr/bin/env bash
# End-to-end: `mvbrdf server` as its own process on a loopback port chosen by
# the OS, queried by `mvbrdf jobs` over a real channel, stopped by SIGTERM;
# its state survives a restart on the same data directory.
# Usage: cli_server_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

check "server help" 0 "--listen" -- "$bin" server --help
check "server needs --data" 2 "--data: required" -- "$bin" server --listen 127.0.0.1:0
check "server rejects a bad address" 2 "--listen: expected host:port" -- "$bin" server --listen nowhere --data "$work/x"
check "jobs needs --server" 2 "--server: required" -- "$bin" jobs

expect "server starts and prints its address" start_server "$work/server1.log"
check "jobs on an empty server" 0 "no jobs" -- "$bin" jobs --server "$address"
check "jobs as JSON" 0 "{" -- "$bin" jobs --server "$address" --json
kill -TERM "$pid"
wait "$pid"
rc=$?
expect "SIGTERM stops the server cleanly (exit $rc)" test "$rc" -eq 0
expect "state directory kept" test -f "$work/data/state.db"
check "jobs without a server" 4 "mvbrdf jobs: error" -- "$bin" jobs --server "$address"

expect "server restarts on the same data" start_server "$work/server2.log"
check "jobs after the restart" 0 "no jobs" -- "$bin" jobs --server "$address"
kill -TERM "$pid"
wait "$pid"

summary
