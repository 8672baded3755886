#!/usr/bin/env bash
# Service benchmark (the figures), natively on loopback: one densemap-server; one robot replaying a
# sequence at 10 Hz; query clients in their own process. Prints one JSON summary per run (in out/bench/).
#   tools/service_bench.sh [SOURCE] [LOOPS]     default: ../shared/data/kitti00, 3 loops (180 scans)
# Step 5 repeats step 2 with --realtime-priority 10 on a fresh server and the client, when this user may.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source="${1:-$root/../shared/data/kitti00}"
loops="${2:-3}"
bin="$root/build"
out="$root/out/bench"
mkdir -p "$out"
domain="${DENSEMAP_DOMAIN:-77}"
dds=(--domain "$domain" --loopback)
# DENSEMAP_SERVER_ARGS adds server flags, e.g. "--realtime-priority 10"; DENSEMAP_CLIENT_ARGS adds flags of
# the 100 Hz query client of step 2, e.g. "--realtime-priority 10" (the back-to-back clients of steps 3-4
# keep the defaults: at real-time priority they would take the cores from the map); DENSEMAP_SERVER_BIN
# runs another densemap-server binary (A/B runs against an older build).
# shellcheck disable=SC2086
rm -rf "$out/server-data" "$out/server-data-realtime"  # each run starts from an empty map
"${DENSEMAP_SERVER_BIN:-$bin/server/densemap-server}" "${dds[@]}" --resolution 0.2 --data-dir "$out/server-data" \
  ${DENSEMAP_SERVER_ARGS:-} > "$out/server.log" 2>&1 &
server=$!
trap 'kill -INT $server 2>/dev/null || true; wait $server 2>/dev/null || true' EXIT
seconds=$(( loops * 6 ))

echo "== 1. one robot at 10 Hz, no queries: every scan processed? publish-to-map latency"
"$bin/client/densemap-replay" "${dds[@]}" --source "$source" --rate 10 --loops "$loops" --robot-prefix plain \
  --summary-json "$out/robot_only.json" --log-level warn

echo "== 2. one robot at 10 Hz + one query client (own process), 1,000-point queries at 100 Hz"
"$bin/client/densemap-replay" "${dds[@]}" --source "$source" --rate 10 --loops "$loops" --robot-prefix with-queries \
  --summary-json "$out/robot_with_queries.json" --log-level warn &
robot=$!
sleep 1
# shellcheck disable=SC2086
"$bin/client/densemap-replay" "${dds[@]}" --robots 0 --duration $(( seconds - 2 )) --query-clients 1 \
  --query-rate 100 --query-points 1000 ${DENSEMAP_CLIENT_ARGS:-} --summary-json "$out/query_100hz.json" --log-level warn
wait $robot

echo "== 3. one robot at 10 Hz + four query clients back to back (throughput)"
"$bin/client/densemap-replay" "${dds[@]}" --source "$source" --rate 10 --loops "$loops" --robot-prefix with-load \
  --summary-json "$out/robot_with_load.json" --log-level warn &
robot=$!
sleep 1
"$bin/client/densemap-replay" "${dds[@]}" --robots 0 --duration $(( seconds - 2 )) --query-clients 4 \
  --query-points 1000 --summary-json "$out/query_4clients.json" --log-level warn
wait $robot

echo "== 4. the same four clients on the idle server (no scans streaming)"
"$bin/client/densemap-replay" "${dds[@]}" --robots 0 --duration 5 --query-clients 4 --query-points 1000 \
  --summary-json "$out/query_4clients_idle.json" --log-level warn
echo "== 5. step 2 with real-time query threads: a fresh server and the client at --realtime-priority 10"
if chrt -f 10 true 2>/dev/null; then
  kill -INT $server 2>/dev/null || true
  wait $server 2>/dev/null || true
  # shellcheck disable=SC2086
  "${DENSEMAP_SERVER_BIN:-$bin/server/densemap-server}" "${dds[@]}" --resolution 0.2 --realtime-priority 10 \
    --data-dir "$out/server-data-realtime" ${DENSEMAP_SERVER_ARGS:-} > "$out/server_realtime.log" 2>&1 &
  server=$!
  sleep 2
  "$bin/client/densemap-replay" "${dds[@]}" --source "$source" --rate 10 --loops "$loops" \
    --robot-prefix realtime --summary-json "$out/robot_with_queries_realtime.json" --log-level warn &
  robot=$!
  sleep 1
  "$bin/client/densemap-replay" "${dds[@]}" --robots 0 --duration $(( seconds - 2 )) --query-clients 1 \
    --query-rate 100 --query-points 1000 --realtime-priority 10 --summary-json "$out/query_100hz_realtime.json" \
    --log-level warn
  wait $robot
else
  echo "skipped: this user may not use SCHED_FIFO (root, CAP_SYS_NICE or \`ulimit -r 10\`; README, Real-time queries)"
fi
echo "== summaries in $out/*.json"
