#!/usr/bin/env bash
# The main job: installs what is missing, builds, starts densemap-server, replays the built-in simulated
# LiDAR (or the dataset given as the first argument) as a robot at 10 Hz and a simulated 16-beam LiDAR that
# the server densifies with ILN, runs a few queries, renders a
# PNG, saves the map, prints a summary, and stops everything it started. A third, ROS 2 robot publishes
# PointCloud2 + /tf to the server's ROS 2 edge (octomap_server's topics, no ROS installation needed).
#   ./tools/demo.sh                         # simulator
#   ./tools/demo.sh ../shared/data/kitti00  # any source densemap-replay reads
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="$root/out"
mkdir -p "$out"
t0=$(date +%s)
"$root/tools/install-deps.sh" --programs
t1=$(date +%s)
echo "== building densemap-server, densemap-replay, densemap-query and the ILN plugin (a few minutes on 2"
echo "   cores the first time; progress in out/build.log)"
if ! "$root/tools/build.sh" --programs > "$out/build.log" 2>&1; then
  tail -n 40 "$out/build.log" >&2
  echo "demo: the build failed (above; the whole log is out/build.log)" >&2
  exit 1
fi
t2=$(date +%s)
source="${1:-sim:scans=30}"
domain="${DENSEMAP_DOMAIN:-42}"
bin="$root/build"
dds=(--domain "$domain" --loopback)

echo "== starting densemap-server on DDS domain $domain (loopback; log in out/server.log)"
# A fresh data directory: the journal and snapshots of an earlier demo would otherwise be recovered.
rm -rf "$out/server-data"
"$bin/server/densemap-server" "${dds[@]}" --resolution 0.2 --save-on-exit "$out/demo_map.bt" --densify iln \
  --map-dir "$out/maps" --data-dir "$out/server-data" --ros2 \
  > "$out/server.log" 2>&1 &
server=$!
trap 'kill -INT $server 2>/dev/null || true' EXIT

echo "== replaying $source as robot-0 at 10 Hz"
"$bin/client/densemap-replay" "${dds[@]}" --source "$source" --rate 10 --summary-json "$out/replay.json"

echo "== replaying a 16-beam LiDAR as sparse-1, 40 m to the side: the server densifies its scans to 64 beams"
echo "   with ILN (models/iln) before mapping them"
"$bin/client/densemap-replay" "${dds[@]}" --source "sim:scans=10,beams=16" --rate 10 --robot-prefix sparse \
  --first-robot 1 --robot-offset 0,40,0 --log-level warn

echo "== a ROS 2 robot: the simulator publishing sensor_msgs/PointCloud2 on /cloud_in and its pose on /tf, as a"
echo "   ROS 2 LiDAR driver and tf2 do; the server's ROS 2 edge places each cloud through TF (README \"For ROS 2 users\")"
"$bin/client/densemap-replay" "${dds[@]}" --ros2 --source "sim:scans=10" --rate 10 --log-level warn

echo "== queries"
query() { "$bin/client/densemap-query" "${dds[@]}" "$@"; }
query stats
echo "-- three points (probability, state): on the road, 1 m above it, far away"
query points 0,0,-0.1 0,0,1 0,500,1
echo "-- first occupied cell straight down from (0,0,1.7), and along +y:"
query ray --origin 0,0,1.7 --direction 0,0,-1 --max-range 10
query ray --origin 0,0,1.7 --direction 0,1,0 --max-range 60 --ignore-unknown
echo "-- occupied cells in a 10 m box around the origin:"
query box --min -5,-5,-1 --max 5,5,4 | head -1
query render --output "$out/demo_map.png" --height 1.0
echo "-- commands (their own DDS topic): save the map in the server's map directory, forget a box, load it back"
query save demo.ot
query clear --min -5,-5,-1 --max 5,5,4
query load demo.ot
query box --min -5,-5,-1 --max 5,5,4 | head -1

echo "== stopping the server (SIGINT: drains its queues and saves the map)"
kill -INT "$server"
wait "$server"
trap - EXIT
grep "ROS 2 edge stopped" "$out/server.log" || true
tail -n 3 "$out/server.log"
t3=$(date +%s)
echo "== times: installing packages $((t1 - t0)) s, building $((t2 - t1)) s, the demo itself $((t3 - t2)) s"
echo "== done: out/demo_map.png (left: occupied cells from above by height; right: probability at z = 1 m),"
echo "   out/demo_map.bt (open with octovis), out/maps/demo.ot (saved on request), out/replay.json (counts"
echo "   and latencies), out/server.log"
