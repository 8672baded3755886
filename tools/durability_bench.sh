#!/usr/bin/env bash
# The service-level figures, natively over DDS (docs/BENCHMARKS.md, "Durability: what it costs"),
# every setting beside its baseline in the same run, settings alternating round by round:
#  1. acknowledgement latency (publish to durable ack) of one robot streaming SOURCE at 10 Hz, for the
#     journal off and each --journal-sync-ms; the journal's bytes per scan; the restart of the server on
#     what it wrote, to its "serving" line, after kill -9 (journal replay) and after SIGINT (snapshot on
#     exit), beside a start on an empty data directory;
#  2. robots sustained at 10 Hz (docker/load_test.py, simulated 64x1024 robots, --overflow drop_oldest)
#     with the journal off and on.
# Writes out/durability-bench/*.json and prints a table per part.
#   tools/durability_bench.sh [--rounds N] [--source DIR] [--sync "0 2 10 50"] [--robots "3 4"]
#                             [--fleet-seconds S] [--skip-fleet]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
rounds=2
source="$root/../shared/data/kitti00"
syncs="0 2 10 50"
fleet="3 4"
fleet_s=30
skip_fleet=0
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds="$2"; shift 2 ;;
    --source) source="$2"; shift 2 ;;
    --sync) syncs="$2"; shift 2 ;;
    --robots) fleet="$2"; shift 2 ;;
    --fleet-seconds) fleet_s="$2"; shift 2 ;;
    --skip-fleet) skip_fleet=1; shift ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    *) echo "durability_bench: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
[ -d "$source" ] || [[ "$source" == sim* ]] || { echo "durability_bench: no $source; pass --source sim:scans=60" >&2; exit 2; }
bin="$root/build"
out="$root/out/durability-bench"
rm -rf "$out"; mkdir -p "$out"
domain="${DENSEMAP_DOMAIN:-199}"
dds=(--domain "$domain" --loopback)
server_pid=
cleanup() { [ -n "$server_pid" ] && kill -9 "$server_pid" 2> /dev/null; rm -rf "$out/data"; }
trap cleanup EXIT

# Starts a server on $out/data with the given flags; waits for its "serving" line; sets up_s to the seconds.
start_server() {
  local log="$1"; shift
  local t0; t0=$(date +%s.%N)
  "$bin/server/densemap-server" "${dds[@]}" --resolution 0.2 --data-dir "$out/data" --snapshot-every-scans 0 --duplicate-check 0 \
    --snapshot-every-s 0 "$@" > "$log" 2>&1 &
  server_pid=$!
  until grep -q "serving on DDS domain" "$log"; do
    kill -0 "$server_pid" 2> /dev/null || { echo "durability_bench: the server exited; see $log" >&2; exit 1; }
    sleep 0.01
  done
  up_s=$(python3 -c "import sys; print(f'{float(sys.argv[1]) - float(sys.argv[2]):.2f}')" "$(date +%s.%N)" "$t0")
}
stop_server() {  # SIGNAL
  kill "-$1" "$server_pid"; wait "$server_pid" 2> /dev/null || true; server_pid=
}

echo "== 1. one robot at 10 Hz: acknowledgement latency per --journal-sync-ms, bytes per scan, restarts"
printf '%-6s %-8s %9s %9s %9s %11s %9s %10s %10s\n' round journal "ack p50" "ack p99" "scans" "MB/scan" \
  "cold s" "kill-9 s" "SIGINT s"
for r in $(seq 1 "$rounds"); do
  for s in off $syncs; do
    tag="r$r-sync-$s"
    if [ "$s" = off ]; then flags=(--journal=false); else flags=(--journal=true --journal-sync-ms "$s"); fi
    rm -rf "$out/data"
    start_server "$out/$tag-server.log" "${flags[@]}"; cold=$up_s
    "$bin/client/densemap-replay" "${dds[@]}" --source "$source" --rate 10 --loops 1 --robot-prefix "$tag" \
      --no-resume --summary-json "$out/$tag.json" --log-level warn > /dev/null
    "$bin/client/densemap-query" "${dds[@]}" --json statistics > "$out/$tag-statistics.json"
    kill9=- sigint=-
    if [ "$s" != off ]; then
      stop_server KILL
      start_server "$out/$tag-restart-journal.log" "${flags[@]}"; kill9=$up_s
      stop_server INT  # snapshot on exit
      start_server "$out/$tag-restart-snapshot.log" "${flags[@]}"; sigint=$up_s
    fi
    stop_server INT
    python3 - "$out/$tag.json" "$out/$tag-statistics.json" "$r" "$s" "$cold" "$kill9" "$sigint" <<'EOF'
import json, sys
run, st = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
j = st.get("journal", {})
scans = max(1, run["scans_sent"])
mb = j.get("bytes", 0) / scans / 1e6 if j.get("on") else 0
print(f"{sys.argv[3]:<6} {sys.argv[4]:<8} {run['latency_p50_ms']:9.1f} {run['latency_p99_ms']:9.1f} "
      f"{run['scans_acknowledged']:>4}/{run['scans_sent']:<4} {mb:11.3f} {float(sys.argv[5]):9.2f} "
      f"{sys.argv[6]:>10} {sys.argv[7]:>10}")
EOF
  done
done

if [ "$skip_fleet" = 0 ]; then
  echo "== 2. robots sustained at 10 Hz (simulated 64x1024, ${fleet_s} s, --overflow drop_oldest), journal off / on"
  for r in $(seq 1 "$rounds"); do
    for n in $fleet; do
      for j in false true; do
        tag="fleet-r$r-$n-journal-$j"
        python3 "$root/docker/load_test.py" --build-dir "$bin" --robots "$n" --rate 10 \
          --source sim:scans=20 --query-clients 0 --duration "$fleet_s" --domain "$domain" \
          --server-args "--overflow drop_oldest --journal=$j" --json "$out/$tag.json" > "$out/$tag.log" 2>&1 || true
        python3 - "$out/$tag.json" "$r" "$n" "$j" <<'EOF'
import json, sys
try:
    s = json.load(open(sys.argv[1]))["summary"]
except (OSError, KeyError, ValueError) as e:
    print(f"round {sys.argv[2]} robots {sys.argv[3]} journal {sys.argv[4]}: no report ({e})"); sys.exit(0)
print(f"round {sys.argv[2]} robots {sys.argv[3]} journal {sys.argv[4]:<5}: sent {s['scans_sent']} processed "
      f"{s['scans_processed']} dropped {s['dropped']}; publish-to-map p99 {s['latency_p99_ms']:.0f} ms; "
      f"server {s['cpu_cores_mean']} cores")
EOF
      done
    done
  done
fi
echo "== reports in $out"
