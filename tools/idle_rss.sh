#!/usr/bin/env bash
# Resident memory of an idle densemap-server, with densify off and with ILN (which loads libtorch through
# its plugin), alternating, so the second is the first's baseline in the same run.
#   tools/idle_rss.sh [RUNS]     (default 2; DENSEMAP_SERVER_BIN runs another build)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
server="${DENSEMAP_SERVER_BIN:-$root/build/server/densemap-server}"
runs="${1:-2}"
for ((i = 1; i <= runs; i++)); do
  for densify in none iln; do
    rm -rf "/tmp/densemap-idle-rss-data"
    "$server" --domain 89 --loopback --log-level warn --densify "$densify" --data-dir /tmp/densemap-idle-rss-data \
      > /dev/null 2>&1 &
    pid=$!
    sleep 4
    rss=$(awk '/VmRSS/ {print $2}' "/proc/$pid/status")
    kill -INT "$pid"
    wait "$pid" || true
    echo "run $i, --densify $densify: VmRSS $rss kB"
  done
done
