#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test (unit tests on the simulator and on ../shared/data).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/install-deps.sh" --tests
"$root/tools/build.sh"
cd "$root/build"
ctest --output-on-failure -j 2 "$@"
