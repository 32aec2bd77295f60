#!/usr/bin/env bash
# Security end to end with separate processes (issue #7): `mvbrdf server` with
# a tokens file and a TLS certificate made here by openssl (a CA, a server
# certificate for localhost/127.0.0.1; nothing is committed), one `mvbrdf
# worker` with a worker token, and the client commands with client tokens
# from a file and from MVBRDF_TOKEN. Wrong, missing and wrong-role tokens, a
# plaintext client and a client trusting another CA are refused with a
# one-line reason and a non-zero exit.
# Usage: cli_security_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
chmod 700 "$work"
source "$(dirname "$0")/lib.sh"

# Certificates: a CA, the server's certificate signed by it, another CA.
pki=$work/pki
mkdir -p "$pki"
for ca in ca other_ca; do
  openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj "/CN=$ca" -keyout "$pki/$ca.key" -out "$pki/$ca.pem" \
    2> /dev/null
done
printf 'subjectAltName=DNS:localhost,IP:127.0.0.1\n' > "$pki/san.ext"
openssl req -newkey rsa:2048 -nodes -subj /CN=localhost -keyout "$pki/server.key" -out "$pki/server.csr" 2> /dev/null
openssl x509 -req -in "$pki/server.csr" -CA "$pki/ca.pem" -CAkey "$pki/ca.key" -CAcreateserial -days 2 \
  -extfile "$pki/san.ext" -out "$pki/server.pem" 2> /dev/null
expect "openssl made the server certificate" test -s "$pki/server.pem"

# Tokens: random, each in its own file (mode 600); the worker's only as its
# SHA-256 in the server's file.
token() { head -c 24 /dev/urandom | base64 | tr '+/' '-_'; }
umask 077
token > "$work/alice.token"
token > "$work/bob.token"
token > "$work/worker.token"
token > "$work/wrong.token"
{
  echo "# role name token"
  echo "client alice $(cat "$work/alice.token")"
  echo "client bob $(cat "$work/bob.token")"
  echo "worker gpu-1 sha256:$(tr -d '\n' < "$work/worker.token" | sha256sum | cut -c1-64)"
} > "$work/tokens.txt"
umask 022

check "generate a tiny sequence" 0 "" -- "$bin" synth --cameras 2 --frames 2 --width 64 --height 48 \
  --actor-segments 8 --out "$work/scene"

check "no tokens on a non-loopback address is refused" 2 "allow-unauthenticated" -- \
  "$bin" server --listen 0.0.0.0:0 --data "$work/refused"
check "a bad tokens file names its line" 3 "tokens-bad.txt:1: role" -- bash -c \
  "echo 'root x $(cat "$work/wrong.token")' > '$work/tokens-bad.txt' &&
   '$bin' server --listen 127.0.0.1:0 --data '$work/refused' --tokens-file '$work/tokens-bad.txt'"

cp "$work/tokens.txt" "$work/tokens-open.txt"
chmod 644 "$work/tokens-open.txt"
check "a tokens file others can read is warned about" 4 "tokens-open.txt is readable by other users" -- \
  "$bin" server --listen 127.0.0.1:0 --data /proc/no-such-dir --tokens-file "$work/tokens-open.txt"

"$bin" server --listen 127.0.0.1:0 --data "$work/data" --tokens-file "$work/tokens.txt" \
  --tls-cert "$pki/server.pem" --tls-key "$pki/server.key" > "$work/server.log" 2>&1 &
pid=$!
server_address "$work/server.log" || true
expect "server starts with TLS and tokens" grep -q "TLS, tokens required" "$work/server.log"
port=${address##*:}
server="localhost:$port"
tls=(--tls-ca "$pki/ca.pem")

"$bin" worker --server "$server" "${tls[@]}" --token-file "$work/worker.token" --name w1 --cache "$work/cache" \
  --egl surfaceless > "$work/worker.log" 2>&1 &
wpid=$!

MVBRDF_TOKEN=$(cat "$work/alice.token") "$bin" submit "$work/scene/scene.json" --server "$server" "${tls[@]}" \
  --atlas 64 --outputs light --watch --json > "$work/watch.out" 2> "$work/watch.err"
rc=$?
expect "submit --watch over TLS with MVBRDF_TOKEN succeeds (exit $rc)" test "$rc" -eq 0
expect "the job succeeded" grep -q '"state":"SUCCEEDED"' "$work/watch.out"
job=$(grep -oE '"id": ?"[0-9a-f]{32}"' "$work/watch.out" | head -1 | grep -oE '[0-9a-f]{32}')
expect "submit printed the job id" test -n "$job"
check "alice lists her job (--token-file)" 0 "$job" -- \
  "$bin" jobs --server "$server" "${tls[@]}" --token-file "$work/alice.token"
check "alice fetches her result" 0 "result.json" -- "$bin" fetch "$job" result.json --server "$server" \
  "${tls[@]}" --token-file "$work/alice.token" --out "$work/fetched"
check "bob does not see alice's job" 0 "no jobs" -- \
  "$bin" jobs --server "$server" "${tls[@]}" --token-file "$work/bob.token"
check "bob cannot fetch alice's job" 3 "no such job" -- "$bin" fetch "$job" result.json --server "$server" \
  "${tls[@]}" --token-file "$work/bob.token" --out "$work/bob"
check "bob cannot cancel alice's job" 3 "no such job" -- \
  "$bin" cancel "$job" --server "$server" "${tls[@]}" --token-file "$work/bob.token"
expect "nothing was written for bob" test ! -e "$work/bob/result.json"

# Refusals: a non-zero exit and one line that says why.
one_line() {  # one_line WANT_EXIT PATTERN command...: exit code, pattern, and exactly one line of output
  local want=$1 pattern=$2
  shift 2
  local out rc
  out=$("$@" 2>&1)
  rc=$?
  [ "$rc" -eq "$want" ] && grep -q -- "$pattern" <<< "$out" && [ "$(wc -l <<< "$out")" -eq 1 ] ||
    { echo "  exit $rc: $out"; return 1; }
}
expect "a wrong token: exit 7 and one line" one_line 7 "the token is not known to this server" \
  "$bin" jobs --server "$server" "${tls[@]}" --token-file "$work/wrong.token"
expect "the wrong token is not echoed" bash -c \
  "! '$bin' jobs --server '$server' --tls-ca '$pki/ca.pem' --token-file '$work/wrong.token' 2>&1 |
     grep -qF -- '$(cat "$work/wrong.token")'"
expect "no token: exit 7 and one line" one_line 7 "requires a token" \
  env -u MVBRDF_TOKEN "$bin" jobs --server "$server" "${tls[@]}"
expect "a worker token on the client API: exit 7" one_line 7 'worker token "gpu-1" may not call mvbrdf.v1.Mvbrdf' \
  "$bin" submit "$work/scene/scene.json" --server "$server" "${tls[@]}" --token-file "$work/worker.token"
check "a client token cannot run a worker" 4 'client token "alice" may not call mvbrdf.v1.Workers' -- \
  "$bin" worker --server "$server" "${tls[@]}" --token-file "$work/alice.token" --cache "$work/cache2" \
  --egl surfaceless --max-tasks 1
check "a worker with a wrong token stops with exit 7" 7 "the token is not known to this server" -- \
  "$bin" worker --server "$server" "${tls[@]}" --token-file "$work/wrong.token" --cache "$work/cache3" \
  --egl surfaceless --max-tasks 1
expect "a plaintext client cannot talk to the TLS port" one_line 4 "error" \
  "$bin" jobs --server "$server" --token-file "$work/alice.token"
expect "a client trusting another CA cannot connect" one_line 4 "error" \
  "$bin" jobs --server "$server" --tls-ca "$pki/other_ca.pem" --token-file "$work/alice.token"
check "an unreadable token file is a usage error" 2 "--token-file" -- \
  "$bin" jobs --server "$server" "${tls[@]}" --token-file "$work/missing.token"
check "a 10000-character token is a usage error naming its limit" 2 "at most 4096 characters" -- \
  env MVBRDF_TOKEN="$(printf 'x%.0s' $(seq 1 10000))" "$bin" jobs --server "$server" "${tls[@]}"
expect "the server log holds no token" bash -c \
  "! grep -qF -f <(cat '$work/alice.token' '$work/bob.token' '$work/worker.token' '$work/wrong.token') \
     '$work/server.log' '$work/worker.log'"

kill -TERM "$wpid"
wait "$wpid"
rc=$?
expect "SIGTERM stops the worker cleanly (exit $rc)" test "$rc" -eq 0
kill -TERM "$pid"
wait "$pid"
summary
