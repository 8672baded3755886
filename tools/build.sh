#!/usr/bin/env bash
# Configures and builds densemap in ./build (Release).
#   tools/build.sh              everything: programs, tests and measurement programs (tools/test.sh)
#   tools/build.sh --programs   only what the demo runs: densemap-server, densemap-replay, densemap-query
#                               and the ILN plugin (no GoogleTest, PCL or Cyclone DDS needed)
# Both use the same build directory, so a later full build reuses what --programs compiled.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
case "${1:-}" in
  "") everything=ON targets=() ;;
  --programs) everything=OFF targets=(--target densemap-server densemap-replay densemap-query densemap_iln_plugin) ;;
  -h | --help) sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "build: unknown argument '$1' (usage: tools/build.sh [--programs])" >&2; exit 2 ;;
esac
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDENSEMAP_BUILD_TESTS=$everything \
  -DDENSEMAP_BUILD_BENCHMARKS=$everything > "$root/build.log" 2>&1 || { cat "$root/build.log"; exit 1; }
cmake --build "$root/build" -j "$(nproc)" "${targets[@]}"
