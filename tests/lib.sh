# Shared by the end-to-end test scripts: `check NAME EXPECTED_EXIT PATTERN -- command...`
# runs the command, compares its exit code and looks for PATTERN in its output;
# `summary` prints the closing "N passed, N failed" line and sets the exit code.
failures=0
passes=0

check() {
  local name=$1 want=$2 pattern=$3
  shift 4
  local out rc
  out=$("$@" 2>&1)
  rc=$?
  if [ "$rc" -ne "$want" ]; then
    echo "FAIL $name: exit $rc, expected $want"; echo "$out" | tail -5; failures=$((failures + 1)); return
  fi
  if ! grep -q -- "$pattern" <<<"$out"; then
    echo "FAIL $name: output lacks '$pattern'"; echo "$out" | tail -5; failures=$((failures + 1)); return
  fi
  echo "ok   $name"; passes=$((passes + 1))
}

# expect NAME CONDITION...: passes when the command CONDITION succeeds.
expect() {
  local name=$1
  shift
  if "$@"; then echo "ok   $name"; passes=$((passes + 1)); else echo "FAIL $name"; failures=$((failures + 1)); fi
}

# start_server LOG: starts `$bin server` on a loopback port the OS picks, with
# its state in $work/data; sets $pid and $address once it prints its address.
start_server() {
  "$bin" server --listen 127.0.0.1:0 --data "$work/data" > "$1" 2>&1 &
  pid=$!
  server_address "$1"
}

# server_address LOG: sets $address once the server writing LOG prints
# "listening on ADDR" (10 s at most); fails if it never does.
server_address() {
  address=""
  for _ in $(seq 1 100); do
    address=$(grep -o 'listening on [0-9.:]*' "$1" | awk '{print $3}')
    [ -n "$address" ] && return 0
    sleep 0.1
  done
  return 1
}

# wait_for FILE PATTERN SECONDS: succeeds once PATTERN appears in FILE.
wait_for() {  # FILE PATTERN SECONDS
  for _ in $(seq 1 $(( $3 * 10 ))); do grep -q "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done
  return 1
}

summary() {
  echo "$passes passed, $failures failed"
  [ "$failures" -eq 0 ]
}
