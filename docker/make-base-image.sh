#!/usr/bin/env bash
# Makes the base images docker/Dockerfile starts from (debian:12 and debian:12-slim) when they are missing and
# no registry can be reached, from this machine's own Debian mirror: debootstrap --variant=minbase bookworm,
# then docker import. With a registry, `docker pull debian:12` does the same job and this script is not needed.
#
#   docker/make-base-image.sh [--force] [--mirror URL]
#
# The mirror is read from the apt configuration (apt-cache policy: the source of bookworm/main), never
# hard-coded; --mirror overrides it. The image's apt sources are the ones this machine uses for bookworm,
# bookworm-updates and bookworm-security, so packages installed in the image match the host's.
set -euo pipefail

force=0
mirror=""
while [ $# -gt 0 ]; do
  case "$1" in
    --force) force=1 ;;
    --mirror) mirror="$2"; shift ;;
    -h|--help) sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "make-base-image: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done

command -v docker > /dev/null || { echo "make-base-image: docker is not installed (apt-get install docker.io)" >&2; exit 1; }
if [ $force -eq 0 ] && docker image inspect debian:12 > /dev/null 2>&1 &&
   docker image inspect debian:12-slim > /dev/null 2>&1; then
  echo "make-base-image: debian:12 and debian:12-slim are present"
  exit 0
fi
if [ $force -eq 0 ] && timeout 60 docker pull -q debian:12 > /dev/null 2>&1 &&
   timeout 60 docker pull -q debian:12-slim > /dev/null 2>&1; then
  echo "make-base-image: pulled debian:12 and debian:12-slim"
  exit 0
fi

# The mirror this machine installs bookworm from: lines like
#   500 http://deb.debian.org/debian bookworm/main amd64 Packages
policy="$(apt-cache policy 2>/dev/null || true)"
source_of() {  # $1: suite; prints the URI apt uses for "<suite>/main"
  awk -v s="$1/main" '$3 == s && $2 ~ /^https?:/ {print $2; exit}' <<< "$policy"
}
[ -n "$mirror" ] || mirror="$(source_of bookworm)"
if [ -z "$mirror" ]; then
  echo "make-base-image: no bookworm/main source in this machine's apt configuration (apt-cache policy);" \
       "pass --mirror URL" >&2
  exit 1
fi
updates="$(source_of bookworm-updates)"
security="$(source_of bookworm-security)"

command -v debootstrap > /dev/null || {
  echo "make-base-image: installing debootstrap"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap > /dev/null
}

rootfs="$(mktemp -d /tmp/densemap-rootfs.XXXXXX)"
trap 'rm -rf "$rootfs"' EXIT
echo "make-base-image: debootstrap --variant=minbase bookworm from $mirror (about a minute)"
keyring=/usr/share/keyrings/debian-archive-keyring.gpg
debootstrap --variant=minbase ${keyring:+--keyring=$keyring} bookworm "$rootfs" "$mirror" \
  > "$rootfs.log" 2>&1 || { tail -20 "$rootfs.log" >&2; echo "make-base-image: debootstrap failed ($rootfs.log)" >&2; exit 1; }
{
  echo "deb $mirror bookworm main"
  [ -z "$updates" ] || echo "deb $updates bookworm-updates main"
  [ -z "$security" ] || echo "deb $security bookworm-security main"
} > "$rootfs/etc/apt/sources.list"
# As in Debian's own images: no apt caches or package lists in the image.
rm -rf "$rootfs"/var/lib/apt/lists/* "$rootfs"/var/cache/apt/*.bin "$rootfs"/var/cache/apt/archives/*.deb
tar -C "$rootfs" -c . | docker import -c 'CMD ["bash"]' - debian:12 > /dev/null
docker tag debian:12 debian:12-slim
rm -f "$rootfs.log"
echo "make-base-image: debian:12 and debian:12-slim made ($(docker image inspect -f '{{.Size}}' debian:12 |
  awk '{printf "%.0f MB", $1 / 1e6}'))"
