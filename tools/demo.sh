#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job on the built-in simulated source (or on a
# dataset given as the first argument), printing what happened.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/install-deps.sh"
"$root/tools/build.sh" > /dev/null
source="${1:-sim}"
out="$root/out"
mkdir -p "$out"
"$root/build/tools/densemap-map" --source "$source" --resolution 0.2 --output "$out/demo_map.bt"
