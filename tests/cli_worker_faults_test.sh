#!/usr/bin/env bash
# A worker whose own environment fails (issue #19, defect 11): its cache disk
# full, or too little memory for a job's atlas. Before, such a worker took
# the gathers, failed them three times and failed 3 of 4 jobs while a healthy
# worker sat idle, and a worker out of memory aborted (three workers died in
# turn; the job's reason became "lease expired"). Now the worker reports the
# failure as its own (TaskUpdate.worker_fault): the task goes back to the
# queue without using an attempt, the worker stops leasing while its cache
# directory cannot be written, every job succeeds on the healthy worker, and
# the failures name the worker and the cause. The disk is a small tmpfs in a
# private mount namespace (unshare -m; the test runs as root, as CI does).
# Usage: cli_worker_faults_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work/cache_full"
source "$(dirname "$0")/lib.sh"

if [ "$(id -u)" -ne 0 ] || ! unshare -m true 2>/dev/null; then
  echo "FAIL cli_worker_faults needs root and unshare -m (a private tmpfs for the bad worker's disk)"
  exit 1
fi

check "generate a sequence" 0 "" -- "$bin" synth --cameras 3 --frames 8 --width 160 --height 120 \
  --actor-segments 10 --out "$work/b"
opts=(--atlas 128 --no-powell)
"$bin" server --listen 127.0.0.1:0 --data "$work/data" --lease-seconds 5 > "$work/server.log" 2>&1 &
spid=$!
server_address "$work/server.log" || true
expect "the server starts" test -n "$address"

# The bad worker: its cache on an 8 MiB tmpfs, full once it has registered.
cache="$work/cache_full"
unshare -m --propagation private sh -c "mount -t tmpfs -o size=8m mvbrdf-worker-disk '$cache' && \
  exec '$bin' worker --server '$address' --name full-disk --cache '$cache' --egl surfaceless --wait 1" \
  > "$work/full.log" 2>&1 &
bad=$!
expect "the bad worker registers" wait_for "$work/full.log" "registered as" 60
inns() { nsenter -t "$bad" -m -- "$@"; }
free_kib=$(inns df -k --output=avail "$cache" | tail -1 | tr -d ' ')
inns fallocate -l "$((free_kib * 1024))" "$cache/filler"
expect "its disk is full" test "$(inns df -k --output=avail "$cache" | tail -1 | tr -d ' ')" -le 4

# Alone, it takes the first job's gather, fails it as its own and stops
# leasing: the job waits (no attempt used), its task names the worker.
job1=$("$bin" submit "$work/b/scene.json" --server "$address" --client wf "${opts[@]}" 2>/dev/null)
expect "the bad worker stops leasing" wait_for "$work/full.log" "not leasing while the cache directory is unusable" 60
"$bin" jobs --server "$address" --client wf --json > "$work/jobs1.json"
expect "the job is not failed; its gather names the worker and the full disk, no attempt used" /usr/bin/python3 -c "
import json, sys
job = [j for j in json.load(open(sys.argv[1]))['jobs'] if j['id'] == sys.argv[2]][0]
assert job['state'] in ('QUEUED', 'RUNNING'), job
gather = [t for t in job['tasks'] if t['kind'] == 'gather'][0]
assert gather.get('workerFaults', 0) >= 1, gather
assert gather.get('attempts', 0) == 0, gather
err = gather['lastError']
assert 'full-disk' in err and 'own environment' in err, err
assert 'No space left on device' in err or 'cannot write' in err, err
" "$work/jobs1.json" "$job1"

# A healthy worker beside it: every job succeeds there.
"$bin" worker --server "$address" --name healthy --cache "$work/cache_ok" --egl surfaceless --wait 1 \
  > "$work/healthy.log" 2>&1 &
good=$!
jobs=("$job1")
for _ in 1 2 3; do
  jobs+=("$("$bin" submit "$work/b/scene.json" --server "$address" --client wf "${opts[@]}" 2>/dev/null)")
done
for j in "${jobs[@]}"; do
  check "job $j succeeds" 0 "succeeded" -- "$bin" watch "$j" --server "$address" --client wf
done
"$bin" jobs --server "$address" --client wf --json > "$work/jobs2.json"
expect "all 4 jobs succeeded, every task on the healthy worker" /usr/bin/python3 -c "
import json, sys
jobs = json.load(open(sys.argv[1]))['jobs']
assert len(jobs) == 4 and all(j['state'] == 'SUCCEEDED' for j in jobs), [(j['id'], j['state'], j.get('error')) for j in jobs]
workers = {t['worker'] for j in jobs for t in j['tasks']}
assert len(workers) == 1, workers
" "$work/jobs2.json"
expect "the healthy worker ran the gathers" grep -q "gather done" "$work/healthy.log"
expect "the bad worker is still running" kill -0 "$bad"
expect "the bad worker said why it failed the task" grep -q "ended: .*No space left on device\|ended: .*cannot write" \
  "$work/full.log"

# Space again: it leases again (the healthy one stopped) and runs a job.
kill -TERM "$good"
wait "$good"
inns rm -f "$cache/filler"
expect "the bad worker leases again once its disk has space" \
  wait_for "$work/full.log" "the cache directory works again; leasing" 30
check "and runs a job to success" 0 "succeeded" -- \
  "$bin" submit "$work/b/scene.json" --server "$address" --client wf "${opts[@]}" --watch
kill -TERM "$bad"
wait "$bad"

if [ "${MVBRDF_SANITIZED:-0}" = 1 ]; then
  echo "skip the ulimit -v worker: AddressSanitizer cannot start under ulimit -v (the Release suite runs it)"
else
  # Too little memory: a worker under `ulimit -v` and a job at the server's own
  # allowed --atlas 4096 (2.5 GiB to resample, more with the texel pass's
  # light terms, pipeline::LightLoad). The worker fails the task as its own
  # each time (up front, from the estimate), the job fails with that reason and
  # the worker's name, and the worker keeps running: a small job succeeds on it.
  ( ulimit -v 2500000 && exec "$bin" worker --server "$address" --name small-memory --cache "$work/cache_small" \
    --egl surfaceless --wait 1 ) > "$work/small.log" 2>&1 &
  small=$!
  expect "the small worker registers" wait_for "$work/small.log" "registered as" 60
  big=$("$bin" submit "$work/b/scene.json" --server "$address" --client wf --atlas 4096 --no-powell 2>/dev/null)
  check "the big job fails, naming the atlas, its memory and the worker" 5 \
    "atlas 4096x4096 needs about [0-9]* MiB.*small-memory" -- "$bin" watch "$big" --server "$address" --client wf
  expect "the small worker is still running" kill -0 "$small"
  check "and runs a small job to success" 0 "succeeded" -- \
    "$bin" submit "$work/b/scene.json" --server "$address" --client wf "${opts[@]}" --watch
  kill -TERM "$small"
  wait "$small"
fi
kill -TERM "$spid"
wait "$spid"
summary
