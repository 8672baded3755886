#!/usr/bin/env bash
# Does densemap-bench's OctoMap reference time OctoMap as a standalone run does? Alternates, for
# ROUNDS rounds: densemap-bench (grid baseline; its reference runs densemap-octomap-reference as a child
# process) and densemap-octomap-reference run by hand on the same scans. Prints OctoMap's ms per scan from
# both, per round, and the median ratio. DENSEMAP_INPROCESS_BENCH: an older densemap-bench binary whose
# OctoMap ran inside it, timed in the same rounds (the figures docs/BENCHMARKS.md marks superseded).
# DENSEMAP_BENCH_METHODS: the grid methods densemap-bench runs (default baseline; "all" puts a densemap
# method before each of its OctoMap runs, as a full benchmark does).
#   tools/reference_agreement.sh [SOURCE] [SCANS] [RESOLUTION] [ROUNDS]
#   default: ../shared/data/kitti00 0:9 0.2 3
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source="${1:-$root/../shared/data/kitti00}"
scans="${2:-0:9}"
res="${3:-0.2}"
rounds="${4:-3}"
bin="$root/build/tools"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
octomap_ms() {  # the OctoMap line of a densemap-bench --json run
  python3 -c 'import json,sys
for line in sys.stdin:
    j = json.loads(line)
    if j["method"] == "octomap": print("%.1f" % j["update_ms"])'
}
"$bin/densemap-bench" --source "$source" --scans "$scans" --resolution "$res" --backend grid --method "${DENSEMAP_BENCH_METHODS:-baseline}" \
  --no-unnecessary --graph-out "$work/scans.graph" --json > /dev/null
printf '%-6s %-28s %-28s %s\n' round "densemap-bench's reference" "standalone, by hand" \
  "${DENSEMAP_INPROCESS_BENCH:+in-process (older binary)}"
ratios=()
for round in $(seq 1 "$rounds"); do
  tool=$("$bin/densemap-bench" --source "$source" --scans "$scans" --resolution "$res" --backend grid \
    --method "${DENSEMAP_BENCH_METHODS:-baseline}" --no-unnecessary --json | octomap_ms)
  alone=$("$bin/densemap-octomap-reference" --graph "$work/scans.graph" --resolution "$res" 2>/dev/null |
    python3 -c 'import json,sys; j=json.load(sys.stdin); print("%.1f" % (j["total_ms"] / j["scans"]))')
  inproc=""
  if [ -n "${DENSEMAP_INPROCESS_BENCH:-}" ]; then
    inproc=$("$DENSEMAP_INPROCESS_BENCH" --source "$source" --scans "$scans" --resolution "$res" --backend grid \
      --method "${DENSEMAP_BENCH_METHODS:-baseline}" --no-unnecessary --json | octomap_ms)
  fi
  printf '%-6s %-28s %-28s %s\n' "$round" "$tool ms/scan" "$alone ms/scan" "${inproc:+$inproc ms/scan}"
  ratios+=("$(python3 -c "print($tool / $alone)")")
done
python3 -c "import statistics,sys; print(f'median ratio densemap-bench / standalone: {statistics.median(map(float, sys.argv[1:])):.3f}')" \
  "${ratios[@]}"
