#!/usr/bin/env bash
# The include graph reads edge -> service -> core (docs/ARCHITECTURE.md): fails naming every include that
# runs back up, and every include of tools/ from server/ or client/.
#   tests/layout/check_includes.sh [REPO_ROOT]
set -uo pipefail
root="${1:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
cd "$root" || exit 2
bad=0
check() {  # check WHAT DIRS... -- PATTERN
  local what="$1"; shift
  local dirs=()
  while [ "$1" != "--" ]; do dirs+=("$1"); shift; done
  shift
  local hits
  hits=$(grep -rnE "$1" "${dirs[@]}" --include='*.h' --include='*.cpp' --include='*.hpp' || true)
  if [ -n "$hits" ]; then
    echo "include graph: $what"
    echo "$hits"
    bad=1
  fi
}
check "core/ includes DDS, the service or the clients" core -- \
  '#include [<"](densemap/(msg|server|client)/|fastdds|fastrtps)'
# libtorch's one translation unit is the exception above the core's other files.
if grep -rnE '#include <torch/' core server client | grep -v 'core/densify/src/iln_upsampler.cpp'; then
  echo "include graph: libtorch included outside core/densify/src/iln_upsampler.cpp"; bad=1
fi
check "the service (server/include, server/src) includes DDS, an edge, the clients or libtorch" \
  server/include server/src -- '#include [<"](densemap/(msg|client|server/dds_edge|server/ros2_edge)/|fastdds|fastrtps|torch/)'
# The two edges stand side by side: the ROS 2 edge does not reach into the DDS edge.
check "the ROS 2 edge includes the DDS edge" server/ros2_edge -- '#include [<"]densemap/server/dds_edge/'
check "server/ or client/ includes tools/" server client -- '#include "(common|tools)/'
check "client/ includes the server" client -- '#include "densemap/server/'
[ "$bad" = 0 ] && echo "include graph: edge -> service -> core, nothing runs back up"
exit "$bad"
