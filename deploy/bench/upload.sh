#!/usr/bin/env bash
# The server's upload throughput on loopback (docs/deploy.md "Capacity"): `mvbrdf submit` of one large bundle to a
# `mvbrdf server` with no workers (the job stays queued), plaintext and with TLS + tokens. The second submit of the
# same bundle uploads nothing (content-addressed), so upload seconds = first - second (packing and hashing are in
# both). Usage: deploy/bench/upload.sh MVBRDF SCENE_DIR WORK_DIR   (prints one line per run)
set -euo pipefail
bin=$1 scene=$2 work=$3
rm -rf "$work"
mkdir -p "$work"
"$(dirname "$0")/../make-secrets" "$work/secrets" mvbrdf-server 2>/dev/null
for mode in plaintext tls; do
  args=() client=()
  if [ "$mode" = tls ]; then
    args=(--tokens-file "$work/secrets/tokens" --tls-cert "$work/secrets/tls.crt" --tls-key "$work/secrets/tls.key")
    client=(--tls-ca "$work/secrets/ca.crt" --token-file "$work/secrets/client.token")
  fi
  "$bin" server --listen 127.0.0.1:0 --data "$work/data-$mode" --max-jobs-per-client 0 "${args[@]}" \
    > "$work/server-$mode.log" 2>&1 &
  pid=$!
  for _ in $(seq 100); do grep -q 'listening on' "$work/server-$mode.log" && break; sleep 0.1; done
  address=$(grep -o 'listening on [^ ]*' "$work/server-$mode.log" | cut -d' ' -f3)
  times=()
  for attempt in first second; do
    start=$(date +%s.%N)
    "$bin" submit "$scene/scene.json" --server "$address" "${client[@]}" --atlas 64 > /dev/null 2>&1
    times+=("$(echo "$(date +%s.%N) - $start" | bc)")
  done
  bytes=$(du -cb "$work/data-$mode/bundles" | tail -1 | cut -f1)
  rss=$(awk '/VmHWM/{print $2}' "/proc/$pid/status")
  kill "$pid"
  wait "$pid" || true
  echo "$mode bundle_bytes=$bytes first_s=${times[0]} second_s=${times[1]}" \
    "upload_MiB_per_s=$(echo "$bytes / 1048576 / (${times[0]} - ${times[1]})" | bc -l | cut -c1-6)" \
    "server_peak_rss_KiB=$rss"
done
