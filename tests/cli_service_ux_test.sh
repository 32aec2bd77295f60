#!/usr/bin/env bash
# Issue #20 item 4 (and run's progress lines, item 6): the service as a user
# follows it, with a real `mvbrdf server` and a worker started with --name.
# One line per finished stage (its configuration, worker and metrics), worker
# names in jobs and watch, `artifacts` equal to what `fetch --all` writes,
# fetching a directory of artifacts, report.html as an artifact, the exit
# codes of cancel/artifacts/fetch/watch, and `run`'s stage lines equal to
# result.json's stages (direct and through the in-process service).
# Usage: cli_service_ux_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"
py=/usr/bin/python3

check "generate a tiny sequence" 0 "" -- "$bin" synth --cameras 3 --frames 3 --width 96 --height 72 \
  --actor-segments 8 --out "$work/b"

# --- run: each printed stage line carries result.json's seconds for it, once.
# "NAME done in S s" lines against result.json's stages, in order.
same_stages() {  # STDERR_FILE RESULT_JSON
  $py - "$1" "$2" <<'PY'
import json, re, sys
printed = [(m.group(1), float(m.group(2))) for m in
           (re.match(r'^(\S+)\s+done in ([0-9.]+) s$', l.strip()) for l in open(sys.argv[1])) if m]
rows = [(s['name'], s.get('seconds', 0.0)) for s in json.load(open(sys.argv[2]))['stages']]
ok = [n for n, _ in printed] == [n for n, _ in rows]
ok = ok and all(abs(p - r) <= 0.0051 for (_, p), (_, r) in zip(printed, rows))
if not ok: print('printed', printed, '\nresult.json', rows)
sys.exit(0 if ok and rows else 1)
PY
}
check "run --direct" 0 "" -- "$bin" run "$work/b/scene.json" --out "$work/direct" --atlas 128 --direct
"$bin" run "$work/b/scene.json" --out "$work/direct2" --atlas 128 --direct > /dev/null 2> "$work/direct.err"
expect "run --direct prints each stage once with result.json's seconds" same_stages "$work/direct.err" \
  "$work/direct2/result.json"
"$bin" run "$work/b/scene.json" --out "$work/embedded" --atlas 128 > /dev/null 2> "$work/embedded.err"
expect "run (in-process service) prints each stage once with result.json's seconds" same_stages \
  "$work/embedded.err" "$work/embedded/result.json"
expect "run shows each finished sweep with its configuration and errors" \
  grep -qE '^stage sweep "[^"]+" finished in [0-9.]+ s on .*E_a=.*E_d=' "$work/embedded.err"
expect "run's in-process workers make no report.html unless asked" test ! -e "$work/embedded/report.html"

# --- a server and a named worker.
expect "server starts and prints its address" start_server "$work/server.log"
"$bin" worker --server "$address" --name studio-gpu-1 --cache "$work/cache" --egl surfaceless > "$work/w.log" 2>&1 &
worker=$!
job=$("$bin" submit "$work/b/scene.json" --server "$address" --client ux --atlas 128 2> "$work/submit.err")
expect "submit prints a job id" test -n "$job"
"$bin" watch "$job" --server "$address" --client ux > "$work/watch.out" 2> "$work/watch.err"
rc=$?
expect "watch follows the job to success (exit $rc)" test "$rc" -eq 0
"$bin" watch "$job" --server "$address" --client ux > "$work/replay.out" 2> /dev/null
"$bin" jobs --server "$address" --client ux --json > "$work/jobs.json"

# Exactly one "finished" line per task, naming its key and worker, with numbers.
one_line_per_stage() {  # WATCH_OUTPUT
  $py - "$1" "$work/jobs.json" <<'PY'
import json, re, sys
lines = [l.rstrip('\n') for l in open(sys.argv[1]) if re.match(r'^stage .* finished in ', l)]
tasks = json.load(open(sys.argv[2]))['jobs'][-1]['tasks']
bad = []
for t in tasks:
    head = 'stage %s%s finished in ' % (t['kind'], ' "%s"' % t['key'] if t.get('key') else '')
    mine = [l for l in lines if l.startswith(head)]
    if len(mine) != 1 or not re.search(r'finished in [0-9.]+ s on studio-gpu-1', mine[0]):
        bad.append((t['kind'], t.get('key'), mine))
    elif t['kind'] == 'sweep' and not ('E_a=' in mine[0] and 'E_d=' in mine[0]):
        bad.append(('no metrics', mine[0]))
    elif t['kind'] == 'reflectance' and 'mse_brdf/' not in mine[0]:
        bad.append(('no metrics', mine[0]))
if bad or len(lines) != len(tasks) or not any(t['kind'] == 'sweep' for t in tasks):
    print(bad, len(lines), len(tasks)); sys.exit(1)
PY
}
expect "watch prints one line per finished stage with its key, worker and metrics" one_line_per_stage "$work/watch.out"
expect "a late watch replays the same one line per stage" one_line_per_stage "$work/replay.out"
expect "watch names the worker of a started stage" \
  grep -qE '^stage sweep "[^"]+" started on studio-gpu-1 \(worker [0-9a-f]{32}, task ' "$work/watch.out"
expect "jobs --json names every task's worker by its --name" $py -c "
import json, sys
tasks = json.load(open(sys.argv[1]))['jobs'][-1]['tasks']
sys.exit(0 if tasks and all(t.get('workerName') == 'studio-gpu-1' and t.get('worker') for t in tasks) else 1)" \
  "$work/jobs.json"
check "jobs shows the worker's name" 0 "studio-gpu-1 (" -- "$bin" jobs --server "$address" --client ux

# --- artifacts, fetch --all, a directory of artifacts, report.html.
check "artifacts lists result.json" 0 "result.json" -- "$bin" artifacts "$job" --server "$address" --client ux
"$bin" artifacts "$job" --server "$address" --client ux --json > "$work/artifacts.json"
check "fetch --all" 0 "report.html" -- "$bin" fetch "$job" --all --server "$address" --client ux --out "$work/all"
same_files() {  # DIR PREFIX: the files under DIR are the listed artifacts under PREFIX, byte for byte
  $py - "$work/artifacts.json" "$1" "$2" <<'PY'
import hashlib, json, os, sys
listed = {a['name']: (int(a['size']), a['sha256']) for a in json.load(open(sys.argv[1]))['artifacts']
          if a['name'].startswith(sys.argv[3])}
found = {}
for root, _, files in os.walk(sys.argv[2]):
    for f in files:
        if f in ('.mvbrdf-output', '.mvbrdf.lock'):
            continue  # the output directory's marker and lock (client/output_dir.h), not artifacts
        p = os.path.join(root, f)
        data = open(p, 'rb').read()
        found[os.path.relpath(p, sys.argv[2])] = (len(data), hashlib.sha256(data).hexdigest())
if not listed or found != listed:
    print(sorted(set(found.items()) ^ set(listed.items()))[:5]); sys.exit(1)
PY
}
expect "fetch --all writes exactly the listed artifacts (names, sizes, sha256)" same_files "$work/all" ""
expect "report.html is a non-empty HTML page" \
  bash -c "test -s '$work/all/report.html' && grep -qi '<html' '$work/all/report.html'"
check "fetch report.html alone" 0 "report.html" -- "$bin" fetch "$job" report.html --server "$address" --client ux \
  --out "$work/one"
check "fetch a directory of artifacts" 0 "atlases/kd.exr" -- "$bin" fetch "$job" atlases/ --server "$address" \
  --client ux --out "$work/prefix"
expect "the directory's files are exactly the listed atlases/ artifacts" same_files "$work/prefix" "atlases/"
check "a directory without its slash says what to fetch" 3 'directory of artifacts (fetch "atlases/"' -- \
  "$bin" fetch "$job" atlases --server "$address" --client ux --out "$work/x"
check "an unknown artifact lists the job's artifacts" 3 "its artifacts: .*result.json" -- \
  "$bin" fetch "$job" nope.exr --server "$address" --client ux --out "$work/x"
check "an empty directory lists the job's artifacts" 3 'no artifact under "nope/"' -- \
  "$bin" fetch "$job" nope/ --server "$address" --client ux --out "$work/x"
check "fetch --all with a name is a usage error" 2 "--all" -- \
  "$bin" fetch "$job" result.json --all --server "$address" --client ux --out "$work/x"
check "fetch without a name nor --all" 2 "NAME...: required" -- "$bin" fetch "$job" --server "$address" --out "$work/x"
check "an absolute name is refused as such" 2 "must be a relative path" -- \
  "$bin" fetch "$job" /etc/passwd --server "$address" --out "$work/x"

# --- exit codes.
check "cancel of a succeeded job: nothing to cancel, exit 0" 0 "already succeeded; nothing to cancel" -- \
  "$bin" cancel "$job" --server "$address" --client ux
check "artifacts of an unknown job" 3 "no such job" -- "$bin" artifacts "$(printf 'f%.0s' $(seq 32))" \
  --server "$address" --client ux
check "watch of an unknown job" 3 "no such job" -- "$bin" watch "$(printf 'f%.0s' $(seq 32))" --server "$address"
light=$("$bin" submit "$work/b/scene.json" --server "$address" --client ux --atlas 128 --outputs light 2> /dev/null)
check "a light-table job succeeds" 0 "state: succeeded" -- "$bin" watch "$light" --server "$address" --client ux
check "a light-table job has its report.html too" 0 "report.html" -- \
  "$bin" fetch "$light" report.html result.json --server "$address" --client ux --out "$work/light"
expect "the light table's report is an HTML page" grep -qi '<html' "$work/light/report.html"
kill -TERM "$worker"
wait "$worker"
queued=$("$bin" submit "$work/b/scene.json" --server "$address" --client ux --atlas 128 2> /dev/null)
check "artifacts of a job without results yet" 3 "is queued: its artifacts are listed once it has succeeded" -- \
  "$bin" artifacts "$queued" --server "$address" --client ux
check "fetch --all of a job without results yet" 3 "is queued" -- \
  "$bin" fetch "$queued" --all --server "$address" --client ux --out "$work/x"
check "cancel of a queued job" 0 "cancelled" -- "$bin" cancel "$queued" --server "$address" --client ux
check "artifacts of a cancelled job" 3 "is cancelled: it has no results" -- \
  "$bin" artifacts "$queued" --server "$address" --client ux
kill -TERM "$pid"
wait "$pid"
summary
