#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz, with clang) and runs each for SECONDS (default 20); exits 1 when
# one finds a crash (its input is left in build-fuzz/). Installs clang if it is missing.
#   tools/fuzz.sh [SECONDS]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-20}"
[[ "$seconds" =~ ^[0-9]+$ ]] || { echo "usage: tools/fuzz.sh [SECONDS]" >&2; exit 2; }
command -v clang++ > /dev/null || { echo "fuzz: installing clang"; DEBIAN_FRONTEND=noninteractive apt-get install -y -qq clang > /dev/null; }
cmake -S "$root/tests/fuzz" -B "$root/build-fuzz" -G Ninja -DCMAKE_CXX_COMPILER=clang++ > /dev/null
cmake --build "$root/build-fuzz"
cd "$root/build-fuzz"
for target in fuzz_*; do
  [ -x "$target" ] || continue
  echo "fuzz: $target for $seconds s"
  # Seeds (tests/fuzz/corpus/TARGET, copied so the run's finds stay in build-fuzz) and a dictionary.
  args=()
  if [ -d "$root/tests/fuzz/corpus/$target" ]; then
    mkdir -p "corpus-$target" && cp -n "$root/tests/fuzz/corpus/$target"/* "corpus-$target/"
    args+=("corpus-$target")
  fi
  [ -f "$root/tests/fuzz/$target.dict" ] && args+=("-dict=$root/tests/fuzz/$target.dict")
  status=0
  "./$target" -max_total_time="$seconds" -print_final_stats=1 "${args[@]}" > "$target.log" 2>&1 || status=$?
  grep -E "stat::number_of_executed_units|ERROR|SUMMARY" "$target.log" || true
  [ "$status" -eq 0 ] || { echo "fuzz: $target failed (log build-fuzz/$target.log, crash input in build-fuzz/)" >&2; exit 1; }
done
