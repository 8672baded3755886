#!/usr/bin/env bash
# Installs the Debian packages that are missing (needs root or sudo): tools/apt-packages.txt (the programs)
# and tools/apt-packages-dev.txt (what building the tests and measurement programs adds).
#   tools/install-deps.sh [--tests | --programs]
# --tests: also tools/apt-packages-test.txt (what only running the tests uses, e.g. tshark for the capture
# test). --programs: tools/apt-packages.txt only (docker/Dockerfile, which builds no tests).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
case "${1:-}" in
  "") lists=("$here/apt-packages.txt" "$here/apt-packages-dev.txt") ;;
  --tests) lists=("$here/apt-packages.txt" "$here/apt-packages-dev.txt" "$here/apt-packages-test.txt") ;;
  --programs) lists=("$here/apt-packages.txt") ;;
  *) echo "install-deps: unknown argument '$1' (usage: tools/install-deps.sh [--tests | --programs])" >&2; exit 2 ;;
esac
mapfile -t wanted < <(cat "${lists[@]}" | grep -v '^\s*#' | grep -v '^\s*$')
missing=()
for p in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#wanted[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" > /tmp/densemap-apt.log 2>&1 || {
  echo "install-deps: apt-get failed; see /tmp/densemap-apt.log" >&2
  tail -20 /tmp/densemap-apt.log >&2
  exit 1
}
