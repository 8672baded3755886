#!/usr/bin/env bash
# densemap across hosts: the server, two robots and a query client each in a network namespace of their own,
# joined by veth pairs to a bridge in a namespace of the test's own, DDS over UDP only (no shared memory, so
# the namespaces' common /dev/shm cannot hide the network). Two scenarios:
#   1. multicast discovery (as a LAN does it): faults (a) one robot's link down 5 s mid-stream, then up;
#      (b) a robot process killed (SIGKILL) and restarted;
#   2. multicast blocked by the bridge (no multicast forwarded), discovery through initial peers given to the
#      clients (--dds-peers; the server keeps its defaults):
#      first a robot without peers must fail to find the server (multicast is really off), then
#      fault (c) the server killed (SIGKILL) and restarted while the robots keep publishing.
# Prints a report and writes it as JSON (--json FILE); exits 1 when a check fails: with the default `wait`
# policy nothing a robot saw acknowledged in (a) and (b) may be missing from the map, and robots must resume
# after every fault without being restarted themselves. Everything it creates (namespaces, links, processes,
# files) is removed when it exits, also when it fails or is interrupted. --secure runs every program with
# DDS-Security, each with an identity of its own, and first checks across the network that a participant
# without an identity and a robot of another CA get nothing (README "Security").
#
#   sudo tests/load/cross_host.sh [--json FILE] [--build DIR] [--source SRC] [--domain N] [--keep-logs DIR]
#                                 [--secure] [--scenarios multicast,peers] [--stream-s S]
#
# Needs root (ip netns) and a build (./tools/build.sh). Addresses: 10.213.77.0/24, only inside the namespaces.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="$root/build"
args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    -h|--help) sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) args+=("$1"); shift ;;
  esac
done
[ "$(id -u)" -eq 0 ] || { echo "cross_host: needs root for network namespaces (run with sudo)" >&2; exit 2; }
command -v ip > /dev/null || { echo "cross_host: needs iproute2 (apt-get install iproute2)" >&2; exit 2; }
for b in server/densemap-server client/densemap-replay client/densemap-query; do
  [ -x "$build/$b" ] || { echo "cross_host: $build/$b missing; build first (./tools/build.sh)" >&2; exit 2; }
done

tag="dmx$$"
bridge_ns="$tag-br"
hosts=(srv ra rb q)
work="$(mktemp -d /tmp/densemap-cross-host.XXXXXX)"

cleanup() {
  local status=$?
  for h in "${hosts[@]}" br; do
    local ns="$tag-$h"
    if ip netns list | grep -qw "$ns"; then
      # Every process still running in the namespace (robots, servers, clients), then the namespace itself
      # (which takes its veth ends and the bridge with it).
      for pid in $(ip netns pids "$ns" 2> /dev/null); do kill -9 "$pid" 2> /dev/null || true; done
      ip netns del "$ns" 2> /dev/null || true
    fi
  done
  rm -rf "$work"
  exit $status
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# The bridge, in its own namespace; one veth pair per host, its bridge end in the bridge namespace.
ip netns add "$bridge_ns"
ip -n "$bridge_ns" link add br0 type bridge
ip -n "$bridge_ns" link set br0 type bridge mcast_snooping 0  # flood multicast like an unmanaged switch
ip -n "$bridge_ns" link set br0 up
i=1
for h in "${hosts[@]}"; do
  ns="$tag-$h"
  ip netns add "$ns"
  ip -n "$bridge_ns" link add "p-$h" type veth peer name eth0 netns "$ns"
  ip -n "$bridge_ns" link set "p-$h" master br0 up
  ip -n "$ns" link set lo up
  ip -n "$ns" addr add "10.213.77.$i/24" dev eth0
  ip -n "$ns" link set eth0 up
  i=$((i + 1))
done

python3 "$root/tests/load/cross_host.py" --build "$build" --work "$work" --ns-prefix "$tag" \
  --hosts "srv=10.213.77.1,ra=10.213.77.2,rb=10.213.77.3,q=10.213.77.4" "${args[@]}"
