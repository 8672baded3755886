#!/usr/bin/env bash
# Prints the Debian packages that own the shared libraries the given programs load, one per line (files that
# are not dynamic executables, such as scripts, are skipped). The slim runtime image installs exactly these,
# so tools/apt-packages.txt stays the one list we maintain by hand.
set -euo pipefail
[ $# -gt 0 ] || { echo "usage: tools/runtime-packages.sh PROGRAM..." >&2; exit 2; }
for program in "$@"; do
  ldd "$program" 2>/dev/null | awk '/=> \// {print $3}' || true
done | sort -u | while read -r lib; do
  dpkg-query -S "$(readlink -f "$lib")" 2>/dev/null || dpkg-query -S "$lib" 2>/dev/null || true
done | cut -d: -f1 | sort -u | grep -v -E '^(libc6|libgcc-s1|libstdc\+\+6)$' || true
