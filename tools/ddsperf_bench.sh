#!/usr/bin/env bash
# Query round trips with and without Cyclone DDS's ddsperf on the server's domain, alternating.
#   tools/ddsperf_bench.sh [--help]
# One densemap-server on DDS loopback, one robot streaming the simulator at 10 Hz for the whole run, and
# ROUNDS pairs of query windows (WINDOW seconds each, one query client at 100 Hz asking 1,000 points):
# a window without ddsperf, then one with `ddsperf pub LOAD` and `ddsperf sub` on the same domain (the
# order swaps every round so drift does not favour either). Prints each window's client-side p99, the
# server's CPU seconds in the window, then the medians and their ratio. ddsperf's topic is not densemap's,
# so any change in the server's own CPU time would be work densemap does for foreign traffic; a change in
# the p99 with the server's CPU unchanged is the machine's cores being shared.
# Environment (all optional):
#   ROUNDS=N          pairs of windows (default 5)
#   WINDOW=S          seconds per window (default 10: 1,000 queries)
#   LOAD="..."        ddsperf's publish arguments (default "100Hz size 1k"; e.g. "1kHz size 16k")
#   DENSEMAP_DOMAIN=N DDS domain id (default 93)
set -euo pipefail
if [[ "${1:-}" == "--help" || "${1:-}" == "-h" ]]; then
  sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'
  exit 0
fi
command -v ddsperf > /dev/null || { echo "ddsperf not found: apt-get install cyclonedds-tools" >&2; exit 1; }
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bin="$root/build"
out="$root/out/bench/ddsperf"
rounds="${ROUNDS:-5}"
window="${WINDOW:-10}"
load="${LOAD:-100Hz size 1k}"
domain="${DENSEMAP_DOMAIN:-93}"
dds=(--domain "$domain" --loopback)
rm -rf "$out" && mkdir -p "$out"
# Cyclone on loopback only, no multicast, as the interoperability tests start it.
export CYCLONEDDS_URI="<General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>\
<AllowMulticast>false</AllowMulticast></General><Discovery><Peers><Peer address=\"127.0.0.1\"/></Peers>\
<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>50</MaxAutoParticipantIndex></Discovery>"

pids=()
cleanup() { for p in "${pids[@]}"; do kill -INT "$p" 2> /dev/null || true; done; wait 2> /dev/null || true; }
trap cleanup EXIT
"$bin/server/densemap-server" "${dds[@]}" --resolution 0.2 --data-dir "$out/data" --log-level warn \
  > "$out/server.log" 2>&1 &
server=$!
pids+=("$server")
# 100 simulated scans (10 s of driving) looped for about as long as the windows take: the map stays the
# same size all run, so every window measures the same server.
loops=$(((rounds * (2 * window + 6) + 9) / 10))
"$bin/client/densemap-replay" "${dds[@]}" --wait 30 --source sim:scans=100 --loops "$loops" --rate 10 \
  --log-level warn > "$out/robot.log" 2>&1 &
robot=$!
pids+=("$robot")
sleep 8  # the server matched and the stream at its rate before the first window

cpu_seconds() {  # utime + stime of the server, in seconds
  awk -v hz="$(getconf CLK_TCK)" '{printf "%.2f\n", ($14 + $15) / hz}' "/proc/$server/stat"
}
# One window: prints "<p99 ms> <server CPU s>".
query_window() {
  local c0 c1 line
  c0=$(cpu_seconds)
  line=$("$bin/client/densemap-replay" "${dds[@]}" --wait 30 --robots 0 --duration "$window" \
    --query-clients 1 --query-rate 100 --query-points 1000 --log-level warn 2>&1 | grep "round trip")
  c1=$(cpu_seconds)
  echo "$(sed -E 's/.*p99 ([0-9.]+) ms.*/\1/' <<< "$line") $(awk -v a="$c0" -v b="$c1" 'BEGIN{print b - a}')"
}
with_ddsperf() {
  # shellcheck disable=SC2086
  ddsperf -i "$domain" sub > "$out/ddsperf_sub.log" 2>&1 &
  local sub=$!
  # shellcheck disable=SC2086
  ddsperf -i "$domain" pub $load > "$out/ddsperf_pub.log" 2>&1 &
  local pub=$!
  sleep 2  # discovery, and the stream under way
  query_window
  kill -TERM "$pub" "$sub" 2> /dev/null || true
  wait "$pub" "$sub" 2> /dev/null || true
}

echo "ddsperf load: pub $load + sub on domain $domain; $rounds rounds of ${window} s windows; robot at 10 Hz"
printf "%-6s %-8s %12s %16s\n" round ddsperf "p99 (ms)" "server CPU (s)"
without=() with=() cpu_without=() cpu_with=()
for ((r = 1; r <= rounds; ++r)); do
  for which in $( ((r % 2)) && echo "off on" || echo "on off"); do
    if [[ "$which" == off ]]; then
      read -r p c <<< "$(query_window)"
      without+=("$p") cpu_without+=("$c")
    else
      read -r p c <<< "$(with_ddsperf)"
      with+=("$p") cpu_with+=("$c")
    fi
    printf "%-6s %-8s %12s %16s\n" "$r" "$which" "$p" "$c"
  done
done
median() { printf "%s\n" "$@" | sort -g | awk '{v[NR]=$1} END{print (NR%2) ? v[(NR+1)/2] : (v[NR/2]+v[NR/2+1])/2}'; }
mw=$(median "${without[@]}") mh=$(median "${with[@]}")
cw=$(median "${cpu_without[@]}") ch=$(median "${cpu_with[@]}")
echo "median p99 without ddsperf $mw ms, with it $mh ms: ratio $(awk -v a="$mw" -v b="$mh" 'BEGIN{printf "%.2f", b / a}')"
echo "median server CPU per window without $cw s, with $ch s: ratio $(awk -v a="$cw" -v b="$ch" 'BEGIN{printf "%.2f", b / a}')"
wait "$robot" || echo "the robot exited $?: see $out/robot.log"
tail -n 2 "$out/robot.log"
