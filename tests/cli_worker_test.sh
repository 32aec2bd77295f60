#!/usr/bin/env bash
# End-to-end with separate processes: `mvbrdf server`, two `mvbrdf worker`s
# and the client commands, on a loopback port, as a user would run them.
# Usage: cli_worker_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

check "generate a tiny sequence" 0 "" -- "$bin" synth --cameras 3 --frames 3 --width 96 --height 72 \
  --actor-segments 8 --out "$work/b"
check "worker needs --server" 2 "--server: required" -- "$bin" worker
check "worker rejects a bad --threads" 2 "--threads" -- "$bin" worker --server 127.0.0.1:1 --threads 0

expect "server starts and prints its address" start_server "$work/server.log"
"$bin" worker --server "$address" --name w1 --cache "$work/cache1" --egl surfaceless > "$work/w1.log" 2>&1 &
w1=$!
"$bin" worker --server "$address" --name w2 --cache "$work/cache2" --egl surfaceless > "$work/w2.log" 2>&1 &
w2=$!

"$bin" submit "$work/b/scene.json" --server "$address" --client tester --atlas 128 --watch --json \
  > "$work/watch.out" 2> "$work/watch.err"
rc=$?
expect "submit --watch ends with success (exit $rc)" test "$rc" -eq 0
expect "the job succeeded" grep -q '"state":"SUCCEEDED"' "$work/watch.out"
expect "watch shows progress with an ETA" grep -q '"etaSeconds"' "$work/watch.out"
expect "watch shows a finished sweep with its errors" grep -q '"E_d"' "$work/watch.out"
expect "watch announces the kd atlas" grep -q '"atlases/kd.exr"' "$work/watch.out"
job=$(grep -oE '"id": ?"[0-9a-f]{32}"' "$work/watch.out" | head -1 | grep -oE '[0-9a-f]{32}')
expect "submit printed the job id" test -n "$job"

"$bin" jobs --server "$address" --client tester --json > "$work/jobs.json"
expect "jobs --json names the workers that ran the tasks" grep -qE '"worker": ?"[0-9a-f]' "$work/jobs.json"
expect "jobs --json gives every task a run time" /usr/bin/python3 -c "
import json, sys
jobs = json.load(open(sys.argv[1]))['jobs']
tasks = [t for j in jobs for t in j['tasks']]
sys.exit(0 if tasks and all(t.get('seconds', 0) > 0 for t in tasks) else 1)" "$work/jobs.json"
expect "jobs --json carries the report" grep -q '"chosenConfiguration"' "$work/jobs.json"
check "jobs lists the tasks with their kinds" 0 "reflectance" -- "$bin" jobs --server "$address" --client tester
check "fetch the kd atlas and the report" 0 "" -- "$bin" fetch "$job" atlases/kd.exr result.json \
  --server "$address" --client tester --out "$work/fetched"
expect "the kd atlas arrived" test -s "$work/fetched/atlases/kd.exr"
expect "result.json has the light table" grep -q '"lightConfigurations"' "$work/fetched/result.json"
# Issue #20 item 3: a fetched result names the scene inside its bundle, not a worker's cache, and records the
# request's options; render finds no scene beside it and says how to give one.
expect "the fetched result.json names the scene inside the bundle, with the bundle's hash" /usr/bin/python3 -c "
import json, sys
d = json.load(open(sys.argv[1]))
ok = d['scene'] == 'scene.json' and len(d.get('bundleSha256', '')) == 64 and 'cache' not in json.dumps(d)
sys.exit(0 if ok and d['options']['fitting']['atlasSize'] == 128 and not d['options'].get('commandLine') else 1)" \
  "$work/fetched/result.json"
printf '{"lights": [{"name": "key", "position": [2.0, 3.0, 2.0], "intensity": [1.0, 0.9, 0.8]}]}' > "$work/lights.json"
check "render of a fetched result names the bundle and --scene" 3 "bundle_sha256.*--scene FILE" -- \
  "$bin" render "$work/fetched" --camera cam0 --lights "$work/lights.json" --out "$work/fetched.png"
expect "both workers ran tasks" bash -c "grep -q 'done in' '$work/w1.log' && grep -q 'done in' '$work/w2.log'"

# The same sweep again: the server answers gather from its Sample cache.
"$bin" submit "$work/b/scene.json" --server "$address" --client tester --atlas 128 --outputs light --watch --json \
  > "$work/watch2.out" 2>&1
rc=$?
expect "the repeated sweep succeeds (exit $rc)" test "$rc" -eq 0
"$bin" jobs --server "$address" --client tester --json > "$work/jobs2.json"
expect "jobs --json reports Samples from the cache" grep -qE '"samplesFromCache": ?true' "$work/jobs2.json"

kill -TERM "$w1" "$w2"
wait "$w1"
rc1=$?
wait "$w2"
rc2=$?
expect "SIGTERM stops the workers cleanly (exit $rc1, $rc2)" test "$rc1" -eq 0 -a "$rc2" -eq 0
expect "a worker downloaded the bundle into its cache" bash -c "ls '$work'/cache*/bundles/*.ok > /dev/null"
kill -TERM "$pid"
wait "$pid"
summary
