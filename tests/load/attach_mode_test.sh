#!/usr/bin/env bash
# The compose load-test runner's mode (load_test.py --attach) natively: the server and the clients are
# started here as the compose services would be, the runner only samples the server and reads summaries.
set -euo pipefail
build="$1"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
dir="$(mktemp -d)"
dds=(--domain 161 --loopback)
"$build/server/densemap-server" "${dds[@]}" --statistics-period 1 --data-dir "$dir/data" > "$dir/server.log" 2>&1 &
server=$!
trap 'kill -INT $server 2>/dev/null || true; wait $server 2>/dev/null || true' EXIT
"$build/client/densemap-replay" "${dds[@]}" --source sim:scans=5,beams=16,columns=256 --rate 5 --loops 100 \
  --max-scans 20 --robot-prefix attach --summary-json "$dir/robot-a.json" --log-level warn > /dev/null &
"$build/client/densemap-replay" "${dds[@]}" --robots 0 --duration 4 --query-clients 1 --query-kind box \
  --query-rate 10 --summary-json "$dir/query-a.json" --log-level warn > /dev/null &
python3 "$root/docker/load_test.py" --attach "$dir" --server-pid "$server" --robots 1 --query-clients 1 --duration 4 --grace 60 \
  --max-dropped 0 --json "$dir/report.out"
# The report must hold the robot's scans and the box queries.
python3 - "$dir/report.out" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
s = r["summary"]
assert s["scans_processed"] == 20, s
assert s["query_kinds"]["box"]["queries"] > 10, s
assert len(r["server"]) >= 2, r["server"]
# The report's top-level fields (docker/run-load-test.sh --json prints the same).
for key in ("latency_p50_ms", "latency_p99_ms", "query_p50_ms", "query_p99_ms", "server_cpu_percent",
            "duration_s"):
    assert isinstance(r[key], (int, float)), (key, r.get(key))
assert r["containers"] is False, r["containers"]
assert set(r["server_rss_mb"]) == {"start", "end"} and r["server_rss_mb"]["end"] > 0, r["server_rss_mb"]
assert [(x["sent"], x["processed"], x["dropped"], x["rejected"]) for x in r["robots"]] == [(20, 20, 0, 0)], r["robots"]
assert r["robots"][0]["robot"] == "attach-0", r["robots"]
assert 0 < r["latency_p50_ms"] <= r["latency_p99_ms"], r
print("attach mode report ok:", s["scans_processed"], "scans,", s["query_kinds"]["box"]["queries"], "box queries")
PY
