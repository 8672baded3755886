#!/usr/bin/env bash
# Installs the Debian packages of tools/apt-packages.txt that are missing (needs root or sudo).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
# --tests: also tools/apt-packages-test.txt (what only the tests use, e.g. tshark for the capture test).
lists=("$here/apt-packages.txt")
[ "${1:-}" = "--tests" ] && lists+=("$here/apt-packages-test.txt")
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
