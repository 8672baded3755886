#!/usr/bin/env bash
# Builds the unit tests labelled `sanitize` (densemap_test(... SANITIZE ...): the core's and the parsers')
# with AddressSanitizer and UndefinedBehaviorSanitizer (build-asan/, GCC) and runs them with ctest -L
# sanitize; any report fails the run. The KITTI and HILTI exactness cases are left
# to the normal build (under the sanitizers they take many minutes); la3dm and the simulator cases run.
# Installs what is missing. Prints the time it took.
#   tools/sanitize.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
start=$(date +%s)
"$root/tools/install-deps.sh"
# -O1 -g1: what the sanitizers' own documentation suggests for speed with usable reports (line tables only:
# reports keep file:line); it builds much faster than -O2 -g, the longest step of CI. A unity build (each
# target's sources compiled eight at a time, so the shared headers are parsed once per batch) cuts the build
# further (docs/BENCHMARKS.md); the normal build stays one file per translation unit, so it still checks
# that every file includes what it uses.
cmake -S "$root" -B "$root/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDENSEMAP_SANITIZE=ON -DDENSEMAP_BUILD_ILN_PLUGIN=OFF \
  -DCMAKE_UNITY_BUILD=ON \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" > /dev/null
cmake --build "$root/build-asan" --target densemap_sanitize_tests
cd "$root/build-asan"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:halt_on_error=1:suppressions=$root/tests/sanitize/asan.supp"
export LSAN_OPTIONS="suppressions=$root/tests/sanitize/lsan.supp"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
status=0
ctest -L sanitize -j 2 -E "Kitti00FirstScans|Hilti2023" --output-on-failure > sanitize.log 2>&1 || status=1
grep -E "tests passed|tests failed|\*\*\*Failed|SUMMARY|runtime error" sanitize.log | head -40
echo "sanitize: done in $(( $(date +%s) - start )) s (log build-asan/sanitize.log)"
exit $status
