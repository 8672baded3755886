#!/usr/bin/env bash
# The densify stage in the server: one 16-beam simulated robot at 10 Hz densified to 64 beams,
# ILN and bilinear alternating on a fresh server each, so both see the same machine state. Prints one row
# per run: the densify stage's p50 / p99, the occupancy update's p50 and the robot's publish-to-map latency.
#   tools/densify_server_bench.sh [ROUNDS] [SCANS]     default: 2 rounds of 100 scans
# DENSEMAP_SERVER_ARGS adds server flags; DENSEMAP_SERVER_BIN runs another server binary (A/B runs).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
rounds="${1:-2}"
scans="${2:-100}"
bin="$root/build"
out="$root/out/densify-bench"
mkdir -p "$out"
domain="${DENSEMAP_DOMAIN:-203}"
dds=(--domain "$domain" --loopback)
server=""
trap '[ -n "$server" ] && { kill -INT $server 2>/dev/null || true; wait $server 2>/dev/null || true; }' EXIT

printf '%-6s %-9s %-24s %-14s %s\n' round densify "densify p50 / p99 ms" "occupancy p50" "publish-to-map p50 / p99 ms"
for round in $(seq 1 "$rounds"); do
  for method in iln bilinear; do
    rm -rf "$out/server-data"
    # shellcheck disable=SC2086
    "${DENSEMAP_SERVER_BIN:-$bin/server/densemap-server}" "${dds[@]}" --resolution 0.2 --densify "$method" \
      --data-dir "$out/server-data" ${DENSEMAP_SERVER_ARGS:-} > "$out/server-$method-$round.log" 2>&1 &
    server=$!
    "$bin/client/densemap-replay" "${dds[@]}" --source "sim:scans=$scans,beams=16" --rate 10 \
      --robot-prefix sparse --first-robot 1 --summary-json "$out/$method-$round.json" --log-level warn > /dev/null
    kill -INT $server
    wait $server || true
    server=""
    python3 - "$out/$method-$round.json" "$round" "$method" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
print(f"{sys.argv[2]:<6} {sys.argv[3]:<9} "
      f"{s['server_stage_densify_p50_ms']:6.1f} / {s['server_stage_densify_p99_ms']:6.1f}{'':10} "
      f"{s['server_stage_occupancy_p50_ms']:6.1f}{'':8} "
      f"{s['latency_p50_ms']:6.1f} / {s['latency_p99_ms']:6.1f}   "
      f"({s['scans_processed']}/{s['scans_sent']} processed)")
EOF
  done
done
