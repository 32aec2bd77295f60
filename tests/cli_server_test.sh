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
# Issue #19: gRPC would wrap a port above 65535 (:99999 listened on 34463).
check "server rejects port 99999" 2 "--listen: the port must be a number in 0..65535" -- \
  "$bin" server --listen 127.0.0.1:99999 --data "$work/x"
check "server rejects port 65536" 2 "0..65535" -- "$bin" server --listen 127.0.0.1:65536 --data "$work/x"
check "server rejects a negative port" 2 "0..65535" -- "$bin" server --listen 127.0.0.1:-1 --data "$work/x"
check "server rejects a port with letters" 2 "0..65535" -- "$bin" server --listen 127.0.0.1:80a --data "$work/x"
check "server rejects a missing host" 2 "with a host" -- "$bin" server --listen :8080 --data "$work/x"
check "server rejects an unbracketed IPv6 address" 2 "needs brackets" -- "$bin" server --listen ::1:8080 --data "$work/x"
check "server rejects a host with a newline" 2 "--listen: expected host:port" -- \
  "$bin" server --listen $'local\nhost:0' --data "$work/x"
printf '{"listen_address": "127.0.0.1:70000", "data_dir": "d"}' > "$work/bad_port.json"
check "a config file's port above 65535 is refused, naming the field" 2 "listen_address: the port must be" -- \
  "$bin" server --config "$work/bad_port.json"
# Issue #19: labels that gRPC metadata cannot carry used to abort (exit 134).
for label in 'café' $'new\nline' $'tab\there' ' lead' 'trail ' ''; do
  check "jobs refuses the --client label $(printf %q "$label")" 2 "--client: must" -- \
    "$bin" jobs --server 127.0.0.1:1 --client "$label"
done
check "watch refuses a non-ASCII --client" 2 "--client: must be printable ASCII" -- \
  "$bin" watch 0123 --server 127.0.0.1:1 --client 'café'
check "cancel refuses a --client with a tab" 2 "--client: must be printable ASCII" -- \
  "$bin" cancel 0123 --server 127.0.0.1:1 --client $'a\tb'
check "fetch refuses a --client with a newline" 2 "--client: must be printable ASCII" -- \
  "$bin" fetch 0123 result.json --server 127.0.0.1:1 --client $'a\nb' --out "$work/f"
check "submit refuses a non-ASCII --client" 2 "--client: must be printable ASCII" -- \
  "$bin" submit "$work/none.json" --server 127.0.0.1:1 --client 'café'
check "worker refuses a --name with a newline" 2 "--name: must be printable ASCII" -- \
  "$bin" worker --server 127.0.0.1:1 --name $'w\n1'

expect "server starts and prints its address" start_server "$work/server1.log"
check "jobs on an empty server" 0 "no jobs" -- "$bin" jobs --server "$address"
check "jobs as JSON" 0 "{" -- "$bin" jobs --server "$address" --json
# Issue #19: gRPC's SO_REUSEPORT let a second server share the port and take
# half of the calls.
check "a second server on the same port is refused, naming the address" 4 \
  "cannot listen on $address: the address is already in use" -- \
  timeout 10 "$bin" server --listen "$address" --data "$work/data2"
# A job on the first server (queued: no worker), so that its answers differ
# from an empty second server's.
"$bin" synth --cameras 2 --frames 2 --width 64 --height 48 --actor-segments 6 --out "$work/tiny" > /dev/null 2>&1
queued=$("$bin" submit "$work/tiny/scene.json" --server "$address" --client port --atlas 64 2>/dev/null)
expect "a job is queued on the first server" test -n "$queued"
"$bin" server --listen "$address" --data "$work/data3" > "$work/server_dup.log" 2>&1 &
dup=$!
sleep 1
served=0
for _ in $(seq 1 12); do
  "$bin" jobs --server "$address" --client port | grep -q "$queued" && served=$((served + 1))
done
kill -TERM "$dup" 2>/dev/null
wait "$dup" 2>/dev/null
expect "every call reaches the first server while a second one tries the port ($served of 12)" test "$served" -eq 12
kill -TERM "$pid"
wait "$pid"
rc=$?
expect "SIGTERM stops the server cleanly (exit $rc)" test "$rc" -eq 0
expect "state directory kept" test -f "$work/data/state.db"
check "jobs without a server" 4 "mvbrdf jobs: error" -- "$bin" jobs --server "$address"

# A unix socket likewise: gRPC unlinked the first server's socket and bound anew, so a second server took its
# clients (and removed the socket when it stopped); the first said "listening on unix:1".
sock="$work/mvbrdf.sock"
"$bin" server --listen "unix:$sock" --data "$work/data_unix" > "$work/server_unix.log" 2>&1 &
unix_pid=$!
expect "a server listens on a unix socket and names it" wait_for "$work/server_unix.log" "listening on unix:$sock " 10
"$bin" submit "$work/tiny/scene.json" --server "unix:$sock" --client unix --atlas 64 > /dev/null 2>&1
check "a second server on the same unix socket is refused" 4 "another process is listening on $sock" -- \
  timeout 10 "$bin" server --listen "unix:$sock" --data "$work/data_unix2"
check "the first server still answers on it" 0 "queued" -- "$bin" jobs --server "unix:$sock" --client unix
kill -KILL "$unix_pid"
wait "$unix_pid" 2>/dev/null
check "a stale socket file (its server killed) is taken over" 0 "" -- sh -c \
  "'$bin' server --listen 'unix:$sock' --data '$work/data_unix2' > '$work/server_unix2.log' 2>&1 & p=\$!; \
   for i in \$(seq 1 50); do grep -q listening '$work/server_unix2.log' && break; sleep 0.1; done; \
   '$bin' jobs --server 'unix:$sock' > /dev/null; rc=\$?; kill -TERM \$p; wait \$p; exit \$rc"
touch "$work/not_a_socket"
check "a unix socket path that is a regular file is refused" 4 "exists and is not a socket" -- \
  timeout 10 "$bin" server --listen "unix:$work/not_a_socket" --data "$work/data_unix2"

expect "server restarts on the same data" start_server "$work/server2.log"
check "jobs after the restart" 0 "no jobs" -- "$bin" jobs --server "$address"
check "the queued job survived the restart" 0 "$queued" -- "$bin" jobs --server "$address" --client port
check "health: serving" 0 "SERVING" -- "$bin" health --server "$address"
# Issue #19: the server said SERVING after its data directory was deleted.
mv "$work/data" "$work/data.moved"
expect "health goes NOT_SERVING once the data directory is gone" sh -c \
  "for i in \$(seq 1 30); do '$bin' health --server '$address' 2>&1 | grep -q NOT_SERVING && exit 0; sleep 0.2; done; exit 1"
check "health exits 4 while not serving" 4 "NOT_SERVING" -- "$bin" health --server "$address"
mv "$work/data.moved" "$work/data"
expect "and SERVING again once it is back" sh -c \
  "for i in \$(seq 1 30); do '$bin' health --server '$address' >/dev/null 2>&1 && exit 0; sleep 0.2; done; exit 1"
kill -TERM "$pid"
wait "$pid"

summary
