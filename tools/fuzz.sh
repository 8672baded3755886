#!/usr/bin/env bash
# Builds the libFuzzer targets (-DDENSEMAP_FUZZ=ON: every module with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer; each module declares its own in its fuzz/ folder) and runs each for SECONDS
# (default 20), or only the targets named; exits 1 when one finds a crash (its input is left in
# build-fuzz/fuzz/). Seeds: the module's fuzz/corpus/TARGET, DDS samples serialized by make_dds_seeds, and
# small files from ../shared/data when it is there (copied into build-fuzz, never into the repository).
# Installs clang and its fuzzer runtime if they are missing. Prints one summary line per target.
#   tools/fuzz.sh [SECONDS] [TARGET...]
#   tools/fuzz.sh --runs N [TARGET...]     (each target until N executions; the longer run in BENCHMARKS)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
limit=(-max_total_time=20); what="20 s"
if [ "${1:-}" = "--runs" ]; then
  [[ "${2:-}" =~ ^[0-9]+$ ]] || { echo "usage: tools/fuzz.sh --runs N [TARGET...]" >&2; exit 2; }
  limit=(-runs="$2"); what="$2 runs"; shift 2
elif [ $# -gt 0 ]; then
  [[ "$1" =~ ^[0-9]+$ ]] || { echo "usage: tools/fuzz.sh [SECONDS] [TARGET...]" >&2; exit 2; }
  limit=(-max_total_time="$1"); what="$1 s"; shift
fi
if ! command -v clang++ > /dev/null || ! dpkg -s libclang-rt-14-dev > /dev/null 2>&1; then
  echo "fuzz: installing clang and libclang-rt-14-dev"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq clang libclang-rt-14-dev > /dev/null
fi
# A unity build, as in tools/sanitize.sh: each target's sources compiled eight at a time. -O1 with asserts
# on (no NDEBUG): an assertion a fuzzer trips is a finding.
mkdir -p "$root/build-fuzz"
cmake -S "$root" -B "$root/build-fuzz" -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang \
  -DDENSEMAP_FUZZ=ON -DDENSEMAP_BUILD_TESTS=OFF -DDENSEMAP_BUILD_BENCHMARKS=OFF -DDENSEMAP_BUILD_ILN_PLUGIN=OFF \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g" \
  -DCMAKE_UNITY_BUILD=ON > "$root/build-fuzz/configure.log" 2>&1 || { cat "$root/build-fuzz/configure.log"; exit 1; }
cmake --build "$root/build-fuzz" --target densemap_fuzz_targets
cd "$root/build-fuzz/fuzz"
./make_dds_seeds seeds
./make_ros2_seeds seeds
data="${DENSEMAP_DATA_DIR:-$root/../shared/data}"
seed_from_data() {  # TARGET FILE...: copies the files that exist and are small into the target's seeds
  local target="$1"; shift
  mkdir -p "seeds/$target"
  for f in "$@"; do
    [ -f "$f" ] && [ "$(stat -c %s "$f")" -le 300000 ] && cp "$f" "seeds/$target/data-$(basename "$(dirname "$f")")-$(basename "$f")"
  done
  return 0
}
if [ -d "$data" ]; then
  seed_from_data fuzz_pcd_file "$data"/la3dm/sim_structured/sim_structured_1.pcd "$data"/la3dm/sim_unstructured/sim_unstructured_2.pcd
  seed_from_data fuzz_scan_graph "$data"/octomap/*.graph
  mkdir -p seeds/fuzz_pose_file
  for f in "$data"/kitti00/poses/0.txt "$data"/hilti2023/poses/5.txt; do
    [ -f "$f" ] && { printf '\x00'; cat "$f"; } > "seeds/fuzz_pose_file/data-$(basename "$(dirname "$(dirname "$f")")")"
  done
else
  echo "fuzz: no $data; seeds from the modules' fuzz/corpus only"
fi
# Malloc stack traces dominate the cost of small inputs; crashes still get full traces.
export ASAN_OPTIONS="${ASAN_OPTIONS:-malloc_context_size=2}"
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_*)
# One target: its corpus from the seeds, a run, a summary line; exit 1 on a crash. Two at a time (each
# libFuzzer process uses one core; the machines CI runs on have two).
fuzz_one() {
  local target="$1" rc=0 start runs crashes seeds
  local args=("corpus-$target")
  mkdir -p "corpus-$target"
  local source
  source="$(cat "$target.source")"
  for seeds in "$source/corpus/$target" "seeds/$target"; do
    [ -d "$seeds" ] && cp -n "$seeds"/* "corpus-$target/" 2> /dev/null || true
  done
  [ -f "$source/$target.dict" ] && args+=("-dict=$source/$target.dict")
  start=$(date +%s)
  # shellcheck disable=SC2086 # FUZZ_LIMIT is one flag without spaces
  "./$target" $FUZZ_LIMIT -rss_limit_mb=2048 -print_final_stats=1 "${args[@]}" > "$target.log" 2>&1 || rc=$?
  runs=$(grep -o "stat::number_of_executed_units: [0-9]*" "$target.log" | awk '{print $2}')
  crashes=$(grep -c "Test unit written" "$target.log" || true)
  echo "fuzz: $target ($FUZZ_WHAT): ${runs:-?} executions in $(( $(date +%s) - start )) s, ${crashes} crashes, corpus $(ls "corpus-$target" | wc -l) inputs"
  if [ "$rc" -ne 0 ]; then
    grep -E "ERROR|SUMMARY|runtime error|Test unit written" "$target.log" | head -5
    echo "fuzz: $target failed (log build-fuzz/fuzz/$target.log, crash input in build-fuzz/fuzz/)" >&2
    return 1
  fi
}
export -f fuzz_one
export root FUZZ_LIMIT="${limit[0]}" FUZZ_WHAT="$what"
status=0
runnable=()
for target in "${targets[@]}"; do
  if [ -f "$target" ] && [ -x "$target" ]; then runnable+=("$target"); fi  # fuzz_* also matches logs, .source
done
[ ${#runnable[@]} -gt 0 ] || { echo "fuzz: no built fuzz target among: ${targets[*]}" >&2; exit 1; }
printf '%s\n' "${runnable[@]}" | xargs -P 2 -I{} bash -c 'fuzz_one "$1"' _ {} || status=1
exit $status
