#!/usr/bin/env bash
# The fleet load test in containers, one command: installs what is missing (Debian's docker.io,
# docker-compose, debootstrap), starts a Docker engine if none is running (and stops it again at the end),
# makes the debian:12 base images when they are missing and cannot be pulled (docker/make-base-image.sh),
# builds the image, runs docker/compose.yaml (one server, N robots, M query clients, the runner), prints the
# report and exits 1 when a bound is broken (any dropped scan, a client that failed). --secure: every
# container runs with DDS-Security, each with an identity of its own from a keystore made for this run by
# tools/make-security.sh (server, robot-1..N, client-1..M; README "Security").
#
#   docker/run-load-test.sh [--robots N] [--query-clients M] [--duration S] [--rate HZ] [--source SRC]
#                           [--query-points P] [--domain D] [--server-args "FLAGS"] [--json FILE] [--secure]
#
# Defaults: 2 robots at 10 Hz from the simulator's 64x1024 LiDAR, 4 query clients asking 1,000 points 20
# times a second, 60 s, domain 0. Works with `docker compose` v2 and Debian 12's docker-compose 1.29.
# Needs root (or sudo) for apt and for starting dockerd.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
robots=2 query_clients=4 duration=60 rate=10 source="sim:scans=20" query_points=1000 domain=0 json="" secure=0
server_args=""
usage() { sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; }
while [ $# -gt 0 ]; do
  case "$1" in
    --robots) robots="$2"; shift 2 ;;
    --query-clients) query_clients="$2"; shift 2 ;;
    --duration) duration="$2"; shift 2 ;;
    --rate) rate="$2"; shift 2 ;;
    --source) source="$2"; shift 2 ;;
    --query-points) query_points="$2"; shift 2 ;;
    --domain) domain="$2"; shift 2 ;;
    --server-args) server_args="$2"; shift 2 ;;
    --json) json="$2"; shift 2 ;;
    --secure) secure=1; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "run-load-test: unknown argument '$1'" >&2; usage >&2; exit 2 ;;
  esac
done
for v in robots query_clients duration domain query_points; do
  [[ "${!v}" =~ ^[0-9]+$ ]] || { echo "run-load-test: --${v//_/-} must be a whole number, not '${!v}'" >&2; exit 2; }
done
[[ "$rate" =~ ^[0-9]+(\.[0-9]+)?$ ]] || { echo "run-load-test: --rate must be a number, not '$rate'" >&2; exit 2; }
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
log() { echo "run-load-test: $*"; }

# 1. What is missing, from Debian.
missing=()
for p in docker.io docker-compose debootstrap; do
  dpkg-query -W -f='${Status}' "$p" 2> /dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  log "installing ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" > /tmp/densemap-docker-apt.log 2>&1 || {
    tail -20 /tmp/densemap-docker-apt.log >&2
    echo "run-load-test: apt-get failed (log: /tmp/densemap-docker-apt.log)" >&2
    exit 1
  }
fi

# 2. An engine: the one running, or Debian's dockerd started here (no bridge, no iptables: every container
# uses the host's network) and stopped again when this script ends.
started_dockerd=""
work="$(mktemp -d /tmp/densemap-load.XXXXXX)"
compose_args=()
cleanup() {
  local status=$?
  if [ ${#compose_args[@]} -gt 0 ]; then
    "${compose[@]}" "${compose_args[@]}" down -v --remove-orphans > /dev/null 2>&1 || true
  fi
  if [ -n "$started_dockerd" ]; then
    log "stopping the Docker engine it started (pid $started_dockerd)"
    $sudo kill "$started_dockerd" 2> /dev/null || true
    for _ in $(seq 1 30); do kill -0 "$started_dockerd" 2> /dev/null || break; sleep 1; done
  fi
  rm -rf "$work"
  exit $status
}
trap cleanup EXIT
trap 'exit 130' INT TERM
if ! docker info > /dev/null 2>&1; then
  dockerd_bin="$(command -v dockerd || echo /usr/sbin/dockerd)"
  log "no Docker engine running; starting $dockerd_bin --bridge=none --iptables=false"
  $sudo "$dockerd_bin" --bridge=none --iptables=false > "$work/dockerd.log" 2>&1 &
  started_dockerd=$!
  for _ in $(seq 1 60); do docker info > /dev/null 2>&1 && break; sleep 1; done
  docker info > /dev/null 2>&1 || { tail -20 "$work/dockerd.log" >&2; echo "run-load-test: dockerd did not start" >&2; exit 1; }
fi

# 3. A compose tool: `docker compose` v2 where the client has the plugin, else Debian's docker-compose 1.29.
if docker compose version > /dev/null 2>&1; then
  compose=(docker compose)
elif command -v docker-compose > /dev/null; then
  compose=(docker-compose)
else
  echo "run-load-test: neither 'docker compose' nor docker-compose is available" >&2
  exit 1
fi

# 4. Base images, 5. the image (dependencies layer cached between runs).
"$root/docker/make-base-image.sh"
log "building densemap:latest (first build on a machine: ~6 min, measured 351 s; log $work/build.log)"
t_build=$(date +%s)
docker build --network host -f "$root/docker/Dockerfile" -t densemap:latest "$root" > "$work/build.log" 2>&1 || {
  tail -30 "$work/build.log" >&2
  echo "run-load-test: docker build failed" >&2
  exit 1
}
# The build stage under its own tag too (from the cache, no work), so both sizes can be read.
docker build --network host --target build -f "$root/docker/Dockerfile" -t densemap:build "$root" > /dev/null 2>&1 || true
size() { docker image inspect -f '{{.Size}}' "$1" 2> /dev/null | awk '{printf "%.0f MB", $1 / 1e6}'; }
log "image built in $(( $(date +%s) - t_build )) s: runtime densemap:latest $(size densemap:latest), build stage $(size densemap:build)"

# 6. The run. Results in a host directory the containers' user (uid 999 in the image) may write.
results="$work/results"
mkdir -p "$results"
chown 999 "$results" 2> /dev/null || chmod 777 "$results"
secure_env=(SECURE=0 SECURITY="" SERVER_SECURITY_DIR="")
if [ $secure -eq 1 ]; then
  # A keystore for this run only. The containers get the identity folders, never the CA's key (keystore/
  # private); the containers' user (uid 999) must read the keys.
  "$root/tools/make-security.sh" "$work/keystore" --robots "$robots" --clients "$query_clients" --days 2 \
    > "$work/security.log" 2>&1 || { cat "$work/security.log" >&2; echo "run-load-test: make-security.sh failed" >&2; exit 1; }
  mkdir -p "$work/security"
  for id in server $(seq -f "robot-%g" 1 "$robots") $(seq -f "client-%g" 1 "$query_clients"); do
    cp -r "$work/keystore/$id" "$work/security/"
  done
  chown -R 999 "$work/security" 2> /dev/null || chmod -R a+rX "$work/security"
  secure_env=(SECURE=1 SECURITY="$work/security" SERVER_SECURITY_DIR=/security/server)
  log "secure: DDS-Security identities for the server, $robots robot(s) and $query_clients client(s) in $work/security"
fi
export "${secure_env[@]}"
max_scans=$(awk -v d="$duration" -v r="$rate" 'BEGIN {printf "%d", d * r}')
export ROBOTS=$robots QUERY_CLIENTS=$query_clients DURATION=$duration RATE=$rate SOURCE=$source DOMAIN=$domain \
  QUERY_POINTS=$query_points MAX_SCANS=$max_scans RESULTS=$results SERVER_ARGS=$server_args
project="densemap-load-$$"
compose_args=(-f "$root/docker/compose.yaml" -p "$project")
log "compose (${compose[*]}): $([ $secure -eq 1 ] && echo "secure, ")$robots robot(s) at $rate Hz from $source, $query_clients query client(s), ${duration} s"
"${compose[@]}" "${compose_args[@]}" up -d --no-build --scale robot="$robots" --scale query="$query_clients" \
  > "$work/up.log" 2>&1 || { cat "$work/up.log" >&2; echo "run-load-test: compose up failed" >&2; exit 1; }
runner="$("${compose[@]}" "${compose_args[@]}" ps -q loadtest)"
[ -n "$runner" ] || { echo "run-load-test: the loadtest container did not start" >&2; exit 1; }
status="$(docker wait "$runner")"
docker logs "$runner" 2>&1
server="$("${compose[@]}" "${compose_args[@]}" ps -q server)"
health="$(docker inspect -f '{{if .State.Health}}{{.State.Health.Status}}{{else}}none{{end}}' "$server" 2> /dev/null || echo unknown)"
log "server container health: $health"
if [ "$status" != "0" ]; then  # the clients' own words, before down removes them (a missing summary says why here)
  log "the run failed; the clients' containers and the end of their logs:"
  "${compose[@]}" "${compose_args[@]}" ps 2>&1 || true
  "${compose[@]}" "${compose_args[@]}" logs --no-color --tail 40 robot query 2>&1 || true
fi
"${compose[@]}" "${compose_args[@]}" down -v --remove-orphans > "$work/down.log" 2>&1 || true
compose_args=()
if [ -n "$json" ]; then
  if [ -f "$results/report.json" ]; then
    cp "$results/report.json" "$json"
    log "report: $json"
  else
    echo "run-load-test: the runner wrote no report" >&2
    status=1
  fi
fi
if [ "$health" != "healthy" ]; then
  echo "run-load-test: the server container's HEALTHCHECK did not report healthy ($health)" >&2
  status=1
fi
exit "$status"
