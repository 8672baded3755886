#!/usr/bin/env bash
# kill -9 at seeded random moments while a robot streams scans (kitti00 from ../shared/data, else the
# built-in simulator); after each kill the server restarts on the same data directory and the robot
# (densemap-replay) resends what the server lost. At the end the served map must equal the offline map of
# every scan, node for node, and hold each acknowledged scan exactly once. Writes a JSON report.
#   tests/load/crash_test.sh [--kills N] [--json FILE] [--seed S] [--source SRC] [--loops L] [--dense]
#                            [--build DIR]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
exec python3 "$root/tests/load/crash_test.py" --root "$root" "$@"
