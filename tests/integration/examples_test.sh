#!/usr/bin/env bash
# The README's examples against a real densemap-server: the robot's ten scans are mapped, the query client
# gets an answer for each point and the statistics, and the core example builds its map in-process.
#   tests/integration/examples_test.sh BUILD_DIR
set -euo pipefail
build="$1"
domain=58
data="$(mktemp -d)"
trap 'kill -INT $server 2> /dev/null || true; wait $server 2> /dev/null || true; rm -rf "$data"' EXIT
"$build/server/densemap-server" --domain $domain --loopback --data-dir "$data" --log-level warn &
server=$!
robot=$("$build/examples/example-robot" $domain)
echo "$robot"
[ "$robot" = "10 scans sent, 10 mapped" ] || { echo "examples: the robot's scans were not all mapped"; exit 1; }
query=$("$build/examples/example-query" $domain)
echo "$query"
[ "$(grep -c 'P(occupied) = ' <<< "$query")" = 2 ] || { echo "examples: no answer for both points"; exit 1; }
grep -q "^map version 10, [1-9][0-9]* known cells$" <<< "$query" || { echo "examples: statistics wrong"; exit 1; }
core=$("$build/examples/example-core-api")
echo "$core" | tail -n 1
grep -q "known cells; (6, 0, 0) is " <<< "$core" || { echo "examples: the core example printed no map"; exit 1; }
echo "examples: all three work"
