#!/usr/bin/env bash
# DDS-Security's cost, plain and secure alternating in one run (the figures): for each robot count, one
# plain run and one secure run of docker/load_test.py natively on loopback, N simulated 64x1024 robots at
# 10 Hz on the 0.2 m grid with 4 query clients asking 1,000 points 20 times a second, the server with
# --overflow drop_oldest (a server that falls behind drops scans, so "zero drops" means it kept up). In
# secure mode every program has an identity of its own (tools/make-security.sh), discovery and liveliness
# are encrypted, RTPS messages signed and every topic's data encrypted (AES-GCM-GMAC).
# Per run: scans sent/processed/dropped, publish-to-map and query p50/p99, the CPU of the server and of the
# clients (the encryption's cost is the secure run's CPU less the plain run's at the same load), and the
# time from a robot's start to its writer and ack reader matched with the server's (authentication and the
# permissions handshake included when secure). The last lines give the medians per mode and robot count.
#
#   tools/security_bench.sh [--robots "2 3 4"] [--repeat 2] [--duration 30] [--out DIR]
#
# Needs a build (./tools/build.sh) and openssl.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
robots_list="2 3 4" repeat=2 duration=30 out="$root/out/security_bench"
while [ $# -gt 0 ]; do
  case "$1" in
    --robots) robots_list="$2"; shift 2 ;;
    --repeat) repeat="$2"; shift 2 ;;
    --duration) duration="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    -h|--help) sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "security_bench: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
for n in $robots_list; do
  [[ "$n" =~ ^[0-9]+$ ]] || { echo "security_bench: --robots takes whole numbers, not '$n'" >&2; exit 2; }
done
[[ "$repeat" =~ ^[1-9][0-9]*$ && "$duration" =~ ^[1-9][0-9]*$ ]] ||
  { echo "security_bench: --repeat and --duration must be whole numbers above 0" >&2; exit 2; }
mkdir -p "$out"
rm -f "$out"/*.json
echo "round mode    robots  sent/processed/dropped  map p50/p99 ms   query p50/p99 ms  server cores  clients cores  matched ms"
for k in $(seq 1 "$repeat"); do
  for n in $robots_list; do
    for mode in plain secure; do
      flag=() domain=216
      [ "$mode" = secure ] && flag=(--secure) domain=217
      python3 "$root/docker/load_test.py" --robots "$n" --rate 10 --source sim:scans=20 --robot-offset 0,0,0 \
        --query-clients 4 --query-mix points --query-points 1000 --query-rate 20 --duration "$duration" \
        --server-args "--overflow drop_oldest" --domain "$domain" "${flag[@]}" --json "$out/$mode-$n-$k.json" \
        > "$out/$mode-$n-$k.log" 2>&1 || true
      python3 - "$k" "$mode" "$n" "$out/$mode-$n-$k.json" <<'PY'
import json, sys
k, mode, n, path = sys.argv[1:]
try:
    r = json.load(open(path))
except (OSError, ValueError):
    print(f"{k:>5} {mode:<7} {n:>6}  no report ({path[:-5]}.log)")
    sys.exit()
s = r["summary"]
sent = sum(x["sent"] for x in r["robots"])
proc = sum(x["processed"] for x in r["robots"])
drop = sum(x["dropped"] for x in r["robots"])
m = s.get("robot_matched_ms") or [0]
print(f"{k:>5} {mode:<7} {n:>6}  {sent:>6}/{proc:>6}/{drop:>4}  {r['latency_p50_ms']:7.1f}/{r['latency_p99_ms']:7.1f}"
      f"  {r['query_p50_ms']:7.2f}/{r['query_p99_ms']:7.2f}  {s['cpu_cores_mean']:12.2f}"
      f"  {s['cpu']['clients_cores']:13.2f}  {m[len(m) // 2]:8.0f}")
PY
    done
  done
done
python3 - "$out" <<'PY'
import glob, json, os, statistics, sys
out = sys.argv[1]
rows = {}
for path in glob.glob(os.path.join(out, "*.json")):
    mode, n, _ = os.path.basename(path)[:-5].split("-")
    try:
        r = json.load(open(path))
    except ValueError:
        continue
    s = r["summary"]
    rows.setdefault((int(n), mode), []).append({
        "dropped": sum(x["dropped"] for x in r["robots"]), "map_p99": r["latency_p99_ms"],
        "query_p99": r["query_p99_ms"], "server": s["cpu_cores_mean"], "clients": s["cpu"]["clients_cores"],
        "matched": statistics.median(s.get("robot_matched_ms") or [0])})
med = lambda rs, key: statistics.median(x[key] for x in rs)
print("\nmedians   robots  zero-drop runs  map p99 ms  query p99 ms  server cores  clients cores  matched ms")
for (n, mode), rs in sorted(rows.items()):
    zero = sum(1 for x in rs if x["dropped"] == 0)
    print(f"{mode:<8} {n:>7}  {zero:>6} of {len(rs):<6}  {med(rs, 'map_p99'):10.1f}  {med(rs, 'query_p99'):12.2f}"
          f"  {med(rs, 'server'):12.2f}  {med(rs, 'clients'):13.2f}  {med(rs, 'matched'):10.0f}")
for n in sorted({n for n, _ in rows}):
    p, q = rows.get((n, "plain")), rows.get((n, "secure"))
    if p and q:
        print(f"{n} robots: encryption costs the server {med(q, 'server') - med(p, 'server'):+.2f} cores and the "
              f"clients {med(q, 'clients') - med(p, 'clients'):+.2f} cores (secure less plain, medians); query p99 "
              f"x{med(q, 'query_p99') / max(1e-9, med(p, 'query_p99')):.2f}, map p99 "
              f"x{med(q, 'map_p99') / max(1e-9, med(p, 'map_p99')):.2f}")
PY
