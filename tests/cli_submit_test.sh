#!/usr/bin/env bash
# End-to-end: `mvbrdf submit`, `watch`, `cancel` and `fetch` against a real
# `mvbrdf server` process on a loopback port (no workers: jobs stay queued).
# Usage: cli_submit_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

check "generate a tiny sequence" 0 "" -- "$bin" synth --cameras 2 --frames 2 --width 64 --height 48 \
  --actor-segments 8 --out "$work/b"
check "submit needs --server" 2 "--server: required" -- "$bin" submit "$work/b/scene.json"
check "submit rejects an unknown output" 2 "--outputs" -- "$bin" submit "$work/b/scene.json" --server 127.0.0.1:1 \
  --outputs light,nope
check "watch help names the exit codes" 0 "6 it was cancelled" -- "$bin" watch --help

expect "server starts and prints its address" start_server "$work/server.log"

job1=$("$bin" submit "$work/b/scene.json" --server "$address" --client tester 2> "$work/submit1.err")
rc=$?
expect "submit prints a job id (exit $rc)" test "$rc" -eq 0 -a -n "$job1"
expect "the first submit uploads the bundle" bash -c "! grep -q 'already on the server' '$work/submit1.err'"
check "submitting the same scene again uploads nothing" 0 "bundle already on the server" -- \
  "$bin" submit "$work/b/scene.json" --server "$address" --client tester
check "jobs lists 2 queued jobs" 0 "queued" -- "$bin" jobs --server "$address" --client tester
queued=$("$bin" jobs --server "$address" --client tester | grep -c '^[^ ].*  queued ')
expect "exactly 2 queued jobs (got $queued)" test "$queued" -eq 2

"$bin" watch "$job1" --server "$address" --client tester --json > "$work/watch.out" 2> "$work/watch.err" &
watch_pid=$!
for _ in $(seq 1 50); do grep -q QUEUED "$work/watch.out" && break; sleep 0.1; done
expect "watch replays the queued state" grep -q '"state":"QUEUED"' "$work/watch.out"
check "cancel prints the job's state" 0 "cancelled" -- "$bin" cancel "$job1" --server "$address" --client tester
wait "$watch_pid"
rc=$?
expect "watch ends with the cancelled exit code (exit $rc)" test "$rc" -eq 6
expect "watch printed the cancelled state" grep -q '"state":"CANCELLED"' "$work/watch.out"
expect "every watch line is one JSON object" bash -c "! grep -qv '^{.*}$' '$work/watch.out'"
check "watch of a finished job replays and ends" 6 "cancelled" -- "$bin" watch "$job1" --server "$address" \
  --client tester
check "watch of an unknown job" 3 "mvbrdf watch: error" -- "$bin" watch nosuchjob --server "$address"

check "fetch of an artifact not produced" 3 "atlases/kd.exr" -- "$bin" fetch "$job1" atlases/kd.exr \
  --server "$address" --client tester --out "$work/fetched"
check "fetch refuses a name leaving --out" 2 "relative path" -- "$bin" fetch "$job1" ../x --server "$address" \
  --out "$work/fetched"
check "fetch refuses an absolute name" 2 "relative path" -- "$bin" fetch "$job1" atlases/kd.exr /etc/x \
  --server "$address" --out "$work/fetched"
check "fetch needs --out" 2 "--out: required" -- "$bin" fetch "$job1" atlases/kd.exr --server "$address"

cp -r "$work/b" "$work/bad"
sed -i 's/"fx": [0-9.e+-]*/"fx": -1/' "$work/bad/scene.json"
check "a bad focal length is refused" 3 "fx" -- "$bin" submit "$work/bad/scene.json" --server "$address"
check "a missing scene is refused" 3 "mvbrdf submit: error" -- "$bin" submit "$work/none/scene.json" \
  --server "$address"

kill -TERM "$pid"
wait "$pid"
rc=$?
expect "SIGTERM stops the server cleanly (exit $rc)" test "$rc" -eq 0
check "submit without a server" 4 "mvbrdf submit: error" -- "$bin" submit "$work/b/scene.json" --server "$address"
check "cancel without a server" 4 "mvbrdf cancel: error" -- "$bin" cancel "$job1" --server "$address"

summary
