#!/usr/bin/env bash
# Builds the core's and the parsers' unit tests with AddressSanitizer and UndefinedBehaviorSanitizer
# (build-asan/, GCC) and runs them; any report fails the run. The KITTI and HILTI exactness cases are left
# to the normal build (under the sanitizers they take many minutes); la3dm and the simulator cases run.
# Installs what is missing. Prints the time it took.
#   tools/sanitize.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
start=$(date +%s)
"$root/tools/install-deps.sh"
tests=(test_pcd_file test_source_validation test_sources test_map_file test_maps test_server_config
       test_ray_traversal test_ray_tracer test_mapping_line test_super_rays test_culling_region test_exactness
       test_map_service test_pipeline test_wire test_ros2_point_cloud test_tf_buffer test_ros2_bags
       test_ros2_names test_map_projection test_octomap_params test_journal test_restart test_compact_cells
       test_decay test_map_window test_block_store test_service_window test_iln_weight_head test_changed_cells
       test_openmp_idle_spin test_octree_batch_update test_topic_names)
# -O1 -g1: what the sanitizers' own documentation suggests for speed with usable reports (line tables only:
# reports keep file:line); it builds much faster than -O2 -g, the longest step of CI. A unity build (each
# target's sources compiled eight at a time, so the shared headers are parsed once per batch) cuts the build
# further (docs/BENCHMARKS.md); the normal build stays one file per translation unit, so it still checks
# that every file includes what it uses.
cmake -S "$root" -B "$root/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDENSEMAP_SANITIZE=ON -DDENSEMAP_BUILD_ILN_PLUGIN=OFF \
  -DCMAKE_UNITY_BUILD=ON \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" > /dev/null
cmake --build "$root/build-asan" --target "${tests[@]}"
cd "$root/build-asan"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:halt_on_error=1:suppressions=$root/tests/sanitize/asan.supp"
export LSAN_OPTIONS="suppressions=$root/tests/sanitize/lsan.supp"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Two programs at a time, as ctest -j 2 runs them (each test uses its own temporary files).
run_one() {
  local t="$1"
  if ! "./tests/$t" --gtest_filter="-*Kitti00FirstScans*:*Hilti2023*" --gtest_brief=1 > "$t.log" 2>&1; then
    echo "sanitize: $t FAILED (build-asan/$t.log):"; grep -E "ERROR|runtime error|FAILED|SUMMARY" "$t.log" | head -5
    return 1
  fi
  echo "sanitize: $t passed ($(grep -o '[0-9]* tests\? from [0-9]* test suites\? ran' "$t.log" | head -1))"
}
export -f run_one
status=0
printf '%s\n' "${tests[@]}" | xargs -P 2 -I{} bash -c 'run_one {}' || status=1
echo "sanitize: done in $(( $(date +%s) - start )) s"
exit $status
