#!/usr/bin/env bash
# The layering is checked by the build: configuring a project where a module links one of a higher layer
# fails and names the arrow; the real project configures (it did, or this test would not exist).
#   tests/layering/check_layering.sh REPO_ROOT
set -uo pipefail
root="$1"
scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
out=$(cmake -S "$root/tests/layering/upward_link" -B "$scratch" -DDENSEMAP_MODULE_CMAKE="$root/cmake/DensemapModule.cmake" 2>&1)
status=$?
if [ $status -eq 0 ]; then
  echo "layering: a module linking a higher layer configured without an error"; exit 1
fi
if ! grep -q "module 'bottom' (layer 0) links 'top' (layer 1)" <<< "$out"; then
  echo "layering: the configuration failed without naming the arrow:"; echo "$out"; exit 1
fi
echo "layering: an upward link stops the configuration and is named"
