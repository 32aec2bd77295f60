#!/usr/bin/env bash
# The exit-code table (issue #19): every code of `mvbrdf --help` and of
# client/commands.h provoked through a real command, and the two tables
# agreeing with each other.
#   0 ok, 1 internal error, 2 usage, 3 invalid input, 4 environment (EGL,
#   codecs, files, memory, server unreachable), 5 the watched job failed,
#   6 the watched job was cancelled, 7 the server refused the credentials.
# Usage: cli_exit_codes_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$work"
mkdir -p "$work"
source "$here/lib.sh"
covered=()
code() {  # code N NAME PATTERN -- cmd...: check, and note that N was provoked
  covered+=("$1")
  check "exit $1: $2" "$1" "$3" -- "${@:5}"
}

# The tables: `mvbrdf --help` and the enum in client/commands.h name the same
# codes 0..7.
"$bin" --help > "$work/help.txt"
expect "mvbrdf --help and client/commands.h list the same codes 0..7" /usr/bin/python3 - "$work/help.txt" \
  "$here/../client/commands.h" <<'PY'
import re, sys
help_text = open(sys.argv[1]).read()
table = re.search(r"exit codes:(.*)", help_text, re.S).group(1)
documented = {int(n): what.strip() for n, what in re.findall(r"(\d) ([^,]+?)(?:,|$)", " ".join(table.split()))}
enum = {int(v): name for name, v in re.findall(r"(kExit\w+) = (\d+),", open(sys.argv[2]).read())}
assert sorted(documented) == list(range(8)), documented
assert sorted(enum) == list(range(8)), enum
words = {"kExitOk": "ok", "kExitInternal": "internal", "kExitUsage": "usage", "kExitInvalidInput": "invalid input",
         "kExitEnvironment": "environment", "kExitJobFailed": "failed", "kExitJobCancelled": "cancelled",
         "kExitDenied": "credentials"}
for n, name in enum.items():
    assert words[name] in documented[n], (n, name, documented[n])
PY

check "generate a sequence" 0 "" -- "$bin" synth --cameras 3 --frames 4 --width 160 --height 120 \
  --actor-segments 10 --out "$work/b"
opts=(--atlas 128 --no-powell)

# 0
code 0 "help" "exit codes" -- "$bin" --help
code 0 "a valid scene validates" "valid" -- "$bin" validate "$work/b/scene.json"

# 1: a server that fails a call unexpectedly (INTERNAL).
/usr/bin/python3 "$here/grpc_failing_server.py" > "$work/failing_port" &
failing=$!
wait_for "$work/failing_port" "[0-9]" 10
code 1 "the server failed the call (INTERNAL)" "fails every call" -- \
  "$bin" jobs --server "127.0.0.1:$(cat "$work/failing_port")"
kill "$failing"
wait "$failing" 2>/dev/null

# 2
code 2 "an unknown command" "unknown command" -- "$bin" frobnicate
code 2 "a missing argument" "SCENE" -- "$bin" resample
code 2 "an unknown flag" "--frobnicate" -- "$bin" validate "$work/b/scene.json" --frobnicate
code 2 "a port above 65535" "0..65535" -- "$bin" server --listen 127.0.0.1:99999 --data "$work/d"
# Out-of-range options name the flag the user wrote, not an options struct
# ("AtlasOptions.gutter", "options.shadow_map_size"), before any EGL set-up.
for flag in "--gutter 999" "--chart-angle 0" "--grazing-margin 100" "--depth-tolerance -1" "--shadow-map-size 0"; do
  code 2 "resample $flag" "^mvbrdf resample: ${flag%% *}: must be in" -- \
    "$bin" resample "$work/b/scene.json" --out "$work/r_flags" $flag
done
# run's and submit's likewise (--max-iterations 100001 named options.max_iterations and exited 3;
# run --report --relit-frames 99999999 rendered for hours, though `report` refuses it).
for where in "run --out $work/r_flags" "submit --server 127.0.0.1:1"; do
  code 2 "${where%% *} --max-iterations 100001" "^mvbrdf ${where%% *}: --max-iterations: must be in \[1, 100000\]" -- \
    "$bin" ${where%% *} "$work/b/scene.json" ${where#* } --max-iterations 100001
  code 2 "${where%% *} --kd-prior-strength -1" "^mvbrdf ${where%% *}: --kd-prior-strength: must be finite and >= 0" -- \
    "$bin" ${where%% *} "$work/b/scene.json" ${where#* } --kd-prior-strength -1
done
for frames in 99999999 -5; do
  code 2 "run --report --relit-frames $frames" "^mvbrdf run: --relit-frames: must be in \[0, 360\]" -- \
    timeout 60 "$bin" run "$work/b/scene.json" --direct --report --relit-frames "$frames" --out "$work/r_flags"
done
code 2 "a --client label gRPC cannot carry" "--client: must be printable ASCII" -- \
  "$bin" jobs --server 127.0.0.1:1 --client 'café'

# 3
code 3 "a missing scene file" "no_such" -- "$bin" validate "$work/no_such.json"
printf '{"frames": ' > "$work/broken.json"
code 3 "a scene that is not JSON" "broken.json" -- "$bin" validate "$work/broken.json"

# 4: environment — the server unreachable, memory, the file system, EGL, a port in use.
code 4 "the server is unreachable" "mvbrdf jobs: error" -- "$bin" jobs --server 127.0.0.1:1
if [ "${MVBRDF_SANITIZED:-0}" = 1 ]; then
  echo "skip the ulimit -v rows: AddressSanitizer cannot start under ulimit -v (the Release suite runs them)"
else
  code 4 "an atlas that cannot fit in memory (ulimit -v), up front" "atlas 8192x8192 needs about 10240 MiB" -- \
    bash -c "ulimit -v 2500000 && exec '$bin' resample '$work/b/scene.json' --out '$work/r8192' --atlas 8192"
  code 4 "an allocation that fails under ulimit -v, mid-run" "atlas 4096x4096 needs about 2560 MiB" -- \
    bash -c "ulimit -v 3000000 && exec '$bin' resample '$work/b/scene.json' --out '$work/r4096' --atlas 4096 --save none"
  code 4 "run --direct: the same" "atlas 8192x8192 needs about" -- \
    bash -c "ulimit -v 2500000 && exec '$bin' run '$work/b/scene.json' --direct --out '$work/run8192' --atlas 8192"
fi
if [ "$(id -u)" -eq 0 ] && unshare -m true 2>/dev/null; then
  mkdir -p "$work/ro" "$work/full"
  code 4 "a read-only output directory" "Read-only file system" -- unshare -m --propagation private sh -c \
    "mount -t tmpfs -o ro,size=1m mvbrdf-ro '$work/ro' && exec '$bin' resample '$work/b/scene.json' --out '$work/ro/r' --atlas 128"
  code 4 "a full disk" "No space left on device" -- unshare -m --propagation private sh -c \
    "mount -t tmpfs -o size=128k mvbrdf-full '$work/full' && exec '$bin' synth --cameras 3 --frames 8 --out '$work/full/s'"
else
  echo "FAIL the read-only and full-disk cases need root and unshare -m (a private tmpfs)"
  failures=$((failures + 1))
fi
if "$bin" resample "$work/b/scene.json" --out "$work/rdev" --atlas 64 --egl device > "$work/egl_device.log" 2>&1; then
  echo "skip --egl device: this machine has a hardware EGL device"
else
  code 4 "--egl device without a hardware EGL device" "EGL platform device" -- \
    "$bin" resample "$work/b/scene.json" --out "$work/rdev" --atlas 64 --egl device
fi

# A server (and later a worker) for 4, 5, 6.
"$bin" server --listen 127.0.0.1:0 --data "$work/data" > "$work/server.log" 2>&1 &
spid=$!
server_address "$work/server.log" || true
expect "the server starts" test -n "$address"
code 4 "a port another server holds" "already in use" -- timeout 10 "$bin" server --listen "$address" --data "$work/d2"

# 6: a job cancelled before any worker took it.
job=$("$bin" submit "$work/b/scene.json" --server "$address" --client codes "${opts[@]}" 2>/dev/null)
check "cancel the queued job" 0 "" -- "$bin" cancel "$job" --server "$address" --client codes
code 6 "watch of a cancelled job" "cancelled" -- "$bin" watch "$job" --server "$address" --client codes

# 5: a job that fails (an atlas too small for the mesh's charts).
"$bin" worker --server "$address" --name codes --cache "$work/cache" --egl surfaceless --wait 1 \
  > "$work/worker.log" 2>&1 &
wpid=$!
code 5 "submit --watch of a job that fails" "cannot hold" -- \
  "$bin" submit "$work/b/scene.json" --server "$address" --client codes --atlas 16 --no-powell --watch
kill -TERM "$wpid"
wait "$wpid"
kill -TERM "$spid"
wait "$spid"

# 7: a server with tokens, asked without one and with a wrong one.
printf 'client alice %s\n' "$(printf 'a%.0s' $(seq 1 40))" > "$work/tokens"
chmod 600 "$work/tokens"
printf 'wrong-token\n' > "$work/wrong_token"
"$bin" server --listen 127.0.0.1:0 --data "$work/data_tokens" --tokens-file "$work/tokens" > "$work/server2.log" 2>&1 &
spid=$!
server_address "$work/server2.log" || true
expect "the server with tokens starts" test -n "$address"
code 7 "no token" "" -- env -u MVBRDF_TOKEN "$bin" jobs --server "$address"
code 7 "a wrong token" "" -- env -u MVBRDF_TOKEN "$bin" jobs --server "$address" --token-file "$work/wrong_token"
kill -TERM "$spid"
wait "$spid"

for n in 0 1 2 3 4 5 6 7; do
  expect "exit code $n was provoked" bash -c "printf '%s\n' ${covered[*]} | grep -qx $n"
done
summary
