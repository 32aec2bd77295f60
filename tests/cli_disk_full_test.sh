#!/usr/bin/env bash
# Disk full while the server writes a job's artifacts (issue #7). The server's
# data directory is a small tmpfs in a private mount namespace (unshare -m; the
# test runs as root, as CI does), so the disk really fills: write(2) returns
# ENOSPC. The job must fail at once with a reason that says the disk is full,
# the database must pass PRAGMA integrity_check with every indexed artifact
# on disk and intact, no temporary file may be left behind, and once space is
# freed the same server runs the next job to success.
# Usage: cli_disk_full_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work/data"
source "$(dirname "$0")/lib.sh"

if [ "$(id -u)" -ne 0 ] || ! unshare -m true 2>/dev/null; then
  echo "FAIL cli_disk_full needs root and unshare -m (a private tmpfs for the server's disk)"
  exit 1
fi

check "generate a sequence" 0 "" -- "$bin" synth --cameras 3 --frames 8 --width 160 --height 120 \
  --actor-segments 10 --out "$work/b"
check "generate a second sequence" 0 "" -- "$bin" synth --cameras 3 --frames 8 --width 320 --height 240 \
  --actor-segments 12 --out "$work/b2"
opts=(--atlas 512 --no-powell)

# The server, with a 96 MiB tmpfs as its data directory, in its own mount
# namespace; `inns CMD` runs CMD in that namespace (to fill and inspect it).
data="$work/data"
unshare -m --propagation private sh -c "mount -t tmpfs -o size=96m mvbrdf-disk-full '$data' && \
  exec '$bin' server --listen 127.0.0.1:0 --data '$data' --lease-seconds 5" > "$work/server.log" 2>&1 &
pid=$!
address=""
for _ in $(seq 1 100); do
  address=$(grep -o 'listening on [0-9.:]*' "$work/server.log" | awk '{print $3}')
  [ -n "$address" ] && break
  sleep 0.1
done
expect "the server starts on its tmpfs" test -n "$address"
inns() { nsenter -t "$pid" -m -- "$@"; }
expect "the data directory is the tmpfs" sh -c "nsenter -t $pid -m -- df '$data' | grep -q mvbrdf-disk-full"

"$bin" worker --server "$address" --name w1 --cache "$work/cache" --egl surfaceless --wait 1 > "$work/w1.log" 2>&1 &
wpid=$!

job=$("$bin" submit "$work/b/scene.json" --server "$address" --client disk "${opts[@]}" 2>"$work/submit.err")
expect "the job is submitted" test -n "$job"
expect "the worker reaches the reflectance task" wait_for "$work/w1.log" "leased reflectance" 120
# Fill the disk, leaving 256 KiB: enough for SQLite to record a failure in the
# pages it already has, not for the atlases (a 512² float EXR alone is more).
free_kib=$(inns df -k --output=avail "$data" | tail -1 | tr -d ' ')
inns fallocate -l "$(( (free_kib - 256) * 1024 ))" "$data/filler"
expect "the disk is (almost) full" test "$(inns df -k --output=avail "$data" | tail -1 | tr -d ' ')" -le 300

check "the job fails, and says the disk is full" 5 "No space left on device" -- \
  "$bin" watch "$job" --server "$address" --client disk
"$bin" jobs --server "$address" --client disk --json > "$work/jobs.json" 2>&1
expect "the job is failed at once (one attempt), its error names the artifact" /usr/bin/python3 -c "
import json, sys
job = [j for j in json.load(open(sys.argv[1]))['jobs'] if j['id'] == sys.argv[2]][0]
assert job['state'] == 'FAILED', job['state']
assert 'No space left on device' in job['error'] and 'artifact' in job['error'], job['error']
refl = [t for t in job['tasks'] if t['kind'] == 'reflectance'][0]
assert refl['attempts'] == 1, refl
" "$work/jobs.json" "$job"

# The database is whole, and what it indexes is on disk and intact.
expect "integrity_check ok with the disk full" sh -c \
  "nsenter -t $pid -m -- sqlite3 '$data/state.db' 'PRAGMA integrity_check' | grep -qx ok"
inns sqlite3 "$data/state.db" "SELECT DISTINCT sha256 FROM artifacts" > "$work/indexed.txt"
missing=0
while read -r sha; do
  [ -z "$sha" ] && continue
  got=$(inns sha256sum "$data/artifacts/${sha:0:2}/$sha" 2>/dev/null | awk '{print $1}')
  [ "$got" = "$sha" ] || { echo "indexed artifact $sha is missing or damaged"; missing=$((missing + 1)); }
done < "$work/indexed.txt"
expect "every indexed artifact is on disk and hashes right ($(wc -l < "$work/indexed.txt") checked)" test "$missing" -eq 0
expect "no temporary file is left behind" test -z "$(inns find "$data/artifacts/tmp" -type f 2>/dev/null)"

# An upload while the disk is full: refused with the reason (the bytes that
# fitted stay as a valid prefix; the upload resumes after them).
check "an upload to a full disk is refused with the reason (exit 4: environment)" 4 "No space left on device" -- \
  "$bin" submit "$work/b2/scene.json" --server "$address" --client disk "${opts[@]}"

# Space freed: the same server and worker take the refused bundle and run its
# job to success.
inns rm -f "$data/filler"
job2=$("$bin" submit "$work/b2/scene.json" --server "$address" --client disk "${opts[@]}" 2>"$work/submit2.err")
expect "with space again the refused bundle uploads and its job is queued" test -n "$job2"
check "with space again the next job succeeds" 0 "succeeded" -- "$bin" watch "$job2" --server "$address" --client disk
check "its kd atlas can be fetched" 0 "" -- "$bin" fetch "$job2" atlases/kd.exr --server "$address" --client disk \
  --out "$work/after"
expect "kd fetched" test -s "$work/after/atlases/kd.exr"
# fetch to a full disk of the client's: exit 4 with the reason (it said only "write failed"), no .part left.
mkdir -p "$work/client_full"
check "fetch to a full disk fails, exit 4, and says why" 4 "kd.exr.part: write failed: No space left on device" -- \
  unshare -m --propagation private sh -c "mount -t tmpfs -o size=64k client-full '$work/client_full' && \
    (dd if=/dev/zero of='$work/client_full/filler' bs=4k 2>/dev/null; true) && \
    '$bin' fetch '$job2' atlases/kd.exr --server '$address' --client disk --out '$work/client_full/f'; rc=\$?; \
    if find '$work/client_full' -name '*.part' | grep -q .; then echo 'a .part file is left'; exit 99; fi; exit \$rc"
expect "integrity_check ok at the end" sh -c \
  "nsenter -t $pid -m -- sqlite3 '$data/state.db' 'PRAGMA integrity_check' | grep -qx ok"

kill -TERM "$wpid" 2>/dev/null
kill -TERM "$pid" 2>/dev/null
wait "$wpid" 2>/dev/null
wait "$pid" 2>/dev/null
summary
