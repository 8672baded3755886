#!/usr/bin/env bash
# Containers against native, the same load, alternating: for each robot count, one native run
# (docker/load_test.py) and one run in containers (docker/run-load-test.sh), each N simulated 64x1024 robots
# at 10 Hz on the 0.2 m grid with 4 query clients asking 1,000 points 20 times a second, the server with
# --overflow drop_oldest (a server that falls behind drops scans, so "zero drops" means it kept up).
# Prints one line per run; the JSON reports stay in OUT (default out/container_bench).
#
#   tools/container_bench.sh [--robots "3 4"] [--repeat 2] [--duration 60] [--out DIR]
#
# Needs a build (./tools/build.sh) and what docker/run-load-test.sh needs (root for dockerd).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
robots_list="3 4" repeat=1 duration=60 out="$root/out/container_bench"
while [ $# -gt 0 ]; do
  case "$1" in
    --robots) robots_list="$2"; shift 2 ;;
    --repeat) repeat="$2"; shift 2 ;;
    --duration) duration="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    -h|--help) sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "container_bench: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
mkdir -p "$out"
line() {  # mode robots file
  python3 - "$@" <<'PY'
import json, sys
mode, n, path = sys.argv[1:]
try:
    r = json.load(open(path))
except (OSError, ValueError):
    print(f"{mode:<10} {n:>6}  no report ({path})")
    sys.exit()
sent = sum(x["sent"] for x in r["robots"])
processed = sum(x["processed"] for x in r["robots"])
dropped = sum(x["dropped"] for x in r["robots"])
print(f"{mode:<10} {n:>6} {sent:>6}/{processed:>6}/{dropped:>4}  map p50 {r['latency_p50_ms']:7.1f} p99 "
      f"{r['latency_p99_ms']:7.1f} ms  query p50 {r['query_p50_ms']:.2f} p99 {r['query_p99_ms']:6.2f} ms  "
      f"server {r['server_cpu_percent']:5.1f}% CPU, RSS {r['server_rss_mb']['start']:.0f}->"
      f"{r['server_rss_mb']['end']:.0f} MB")
PY
}
echo "mode       robots  sent/processed/dropped"
for k in $(seq 1 "$repeat"); do
  for n in $robots_list; do
    python3 "$root/docker/load_test.py" --robots "$n" --rate 10 --source sim:scans=20 --robot-offset 0,0,0 \
      --query-clients 4 --query-mix points --query-points 1000 --query-rate 20 --duration "$duration" \
      --server-args "--overflow drop_oldest" --domain 95 --json "$out/native-$n-$k.json" > "$out/native-$n-$k.log" 2>&1 || true
    line native "$n" "$out/native-$n-$k.json"
    "$root/docker/run-load-test.sh" --robots "$n" --query-clients 4 --duration "$duration" --rate 10 \
      --server-args "--overflow drop_oldest" --domain 96 --json "$out/container-$n-$k.json" \
      > "$out/container-$n-$k.log" 2>&1 || true
    line container "$n" "$out/container-$n-$k.json"
  done
done
