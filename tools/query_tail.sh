#!/usr/bin/env bash
# Query round-trip tail under a streaming robot (the diagnosis): one densemap-server on DDS loopback,
# optionally one robot replaying SOURCE at 10 Hz, and one query client at 100 Hz for 16 s (1,600 queries).
#   tools/query_tail.sh [--help]
# Environment (all optional):
#   SOURCE=PATH|sim:...  what the robot replays (default ../shared/data/kitti00); ROBOT=0 runs no robot
#   LOOPS=N              replay loops (default 3: 180 kitti00 scans, 18 s)
#   POINTS=N             points per query (default 1000)
#   SERVER_ARGS="..."    extra densemap-server flags, e.g. "--update-threads 1"
#   CLIENT_ARGS="..."    extra flags of the query client, e.g. "--realtime-priority 10"
#   SERVER_BIN=PATH      another densemap-server binary (A/B runs against an older build)
#   DENSEMAP_DOMAIN=N    DDS domain id (default 91)
set -euo pipefail
if [[ "${1:-}" == "--help" || "${1:-}" == "-h" ]]; then
  sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'
  exit 0
fi
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bin="$root/build"
out="$root/out/bench"
mkdir -p "$out"
dds=(--domain "${DENSEMAP_DOMAIN:-91}" --loopback)
# shellcheck disable=SC2086
rm -rf "$out/query_tail_data"  # each run starts from an empty map
"${SERVER_BIN:-$bin/server/densemap-server}" "${dds[@]}" --resolution 0.2 --data-dir "$out/query_tail_data" \
  ${SERVER_ARGS:-} > "$out/query_tail_server.log" 2>&1 &
server=$!
trap 'kill -INT $server 2>/dev/null || true; wait $server 2>/dev/null || true' EXIT
sleep 2
robot=""
if [[ "${ROBOT:-1}" != 0 ]]; then
  "$bin/client/densemap-replay" "${dds[@]}" --source "${SOURCE:-$root/../shared/data/kitti00}" --rate 10 \
    --loops "${LOOPS:-3}" --robot-prefix tail --log-level warn > "$out/query_tail_robot.log" 2>&1 &
  robot=$!
fi
sleep 1
# shellcheck disable=SC2086
"$bin/client/densemap-replay" "${dds[@]}" --robots 0 --duration 16 --query-clients 1 --query-rate 100 \
  --query-points "${POINTS:-1000}" ${CLIENT_ARGS:-} --log-level warn 2>&1 | grep "round trip"
# The server's own answer time (lock waits included) from its last statistics line.
grep -o "queries p50 [0-9.]* p99 [0-9.]* ms" "$out/query_tail_server.log" | tail -n 1 | sed 's/^/server-side /' || true
if [[ -n "$robot" ]]; then
  wait "$robot"
  tail -n 1 "$out/query_tail_robot.log"
fi
