#!/usr/bin/env bash
# Real containers on this machine (Debian 12, as root): Debian's podman with runc and the
# cgroupfs cgroup manager and explicit nofile/nproc limits (deploy/containers/containers.conf,
# which CONTAINERS_CONF must name for every podman command: `eval "$(deploy/containers.sh env)"`),
# the Debian 12 base image built locally from Debian's packages when it is missing (no
# container registry is reachable here: debootstrap --variant=minbase, then podman
# import, tagged docker.io/library/debian:12 so that `FROM debian:12` finds it), and the
# repository's image, localhost/hapticd:latest, from its Dockerfile (layers cached: a
# code change rebuilds only the code). Idempotent; the first run takes about 7 minutes
# on 2 cores (base image under a minute, the build stage's packages, the build), a run
# after a code change about 5, one with nothing changed seconds.
#   deploy/containers.sh        set up and build the image
#   deploy/containers.sh env    print the CONTAINERS_CONF export line
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
conf="$repo/deploy/containers/containers.conf"
base=docker.io/library/debian:12
image=localhost/hapticd:latest

if [[ "${1:-}" == "env" ]]; then
  echo "export CONTAINERS_CONF=$conf"
  exit 0
fi
[[ $# -eq 0 ]] || { echo "usage: deploy/containers.sh [env]" >&2; exit 2; }
[[ $EUID -eq 0 ]] || { echo "containers.sh: podman here runs as root" >&2; exit 2; }
export CONTAINERS_CONF="$conf"

packages=(podman runc debootstrap podman-compose uidmap slirp4netns golang-github-containernetworking-plugin-dnsname catatonit)
bash "$repo/deploy/apt_install_missing.sh" containers "${packages[@]}"

if ! podman image exists "$base"; then
  echo "containers: building $base with debootstrap" >&2
  rootfs="$(mktemp -d)"
  trap 'rm -rf "$rootfs"' EXIT
  debootstrap --variant=minbase bookworm "$rootfs" http://deb.debian.org/debian >/dev/null
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/*
  tar -C "$rootfs" -c . | podman import --message "debootstrap --variant=minbase bookworm" - "$base" >/dev/null
fi

echo "containers: building $image" >&2
podman build --quiet -t "$image" "$repo" >/dev/null
podman image inspect --format '{{.Size}}' "$image" | awk '{printf "containers: %s, %.0f MB\n", "'"$image"'", $1 / 1e6}' >&2
