#!/usr/bin/env bash
# Shared by `make image` and `make test-image`: picks the container engine and, with podman on a machine that
# reaches no image registry, makes the debian:bookworm-slim base image locally with debootstrap.
# Source it:  . scripts/container-engine.sh   (defines ENGINE, engine_build and ensure_base_image)
# ENGINE=docker|podman overrides the choice; otherwise docker when its daemon answers, else podman.
set -euo pipefail

BASE_IMAGE=docker.io/library/debian:bookworm-slim

pick_engine() {
  if [[ -n ${ENGINE:-} ]]; then return; fi
  if command -v docker >/dev/null && docker info >/dev/null 2>&1; then ENGINE=docker
  elif command -v podman >/dev/null; then ENGINE=podman
  else
    echo "image: neither a running docker daemon nor podman found (apt-get install podman)" >&2
    exit 1
  fi
}

# The Debian mirror this machine's apt uses (first deb822 URIs or one-line `deb` entry for the main archive), so a lab
# with a local mirror builds from it; deb.debian.org when none is found.
machine_debian_mirror() {
  local uri
  uri=$(cat /etc/apt/sources.list.d/*.sources 2>/dev/null \
        | awk '/^URIs:/ { for (i = 2; i <= NF; ++i) if ($i !~ /security/) { print $i; exit } }')
  [[ -n $uri ]] || uri=$(awk '$1 == "deb" && $0 !~ /security/ { for (i = 2; i <= NF; ++i) if ($i ~ /^[a-z]+:\/\//) { print $i; exit } }' \
        /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null)
  echo "${uri:-http://deb.debian.org/debian}"
}

# The machine's own apt sources for Debian (its mirror, its security suite), copied into the local base image so
# that `apt-get` inside the build uses what this machine can reach. Entries of other vendors are left out.
copy_machine_apt_sources() {
  local rootfs=$1 file
  rm -f "$rootfs"/etc/apt/sources.list "$rootfs"/etc/apt/sources.list.d/*
  for file in /etc/apt/sources.list /etc/apt/sources.list.d/*.list /etc/apt/sources.list.d/*.sources; do
    [[ -f $file ]] && grep -q 'debian' "$file" || continue
    cp "$file" "$rootfs$file"
  done
}

# A registry-less machine cannot pull the base: build the same Debian 12 minbase with debootstrap from the machine's
# mirror and tag it with the name the Dockerfile asks for, so the Dockerfile stays the one a user builds anywhere.
ensure_base_image() {
  if "$ENGINE" image inspect "$BASE_IMAGE" >/dev/null 2>&1; then return; fi
  if "$ENGINE" pull -q "$BASE_IMAGE" >/dev/null 2>&1; then return; fi
  if ! command -v debootstrap >/dev/null; then
    echo "image: cannot pull $BASE_IMAGE and debootstrap is missing (apt-get install debootstrap)" >&2
    exit 1
  fi
  local rootfs mirror
  mirror=$(machine_debian_mirror)
  echo "image: $BASE_IMAGE cannot be pulled; building it with debootstrap from $mirror"
  rootfs=$(mktemp -d /tmp/tracemesh-base.XXXXXX)
  debootstrap --variant=minbase bookworm "$rootfs" "$mirror" >"$rootfs.log" 2>&1 \
    || { echo "image: debootstrap failed, see $rootfs.log" >&2; exit 1; }
  copy_machine_apt_sources "$rootfs"
  # Like the published slim image: no downloaded .debs, no package lists.
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/cache/apt/*.bin "$rootfs"/var/lib/apt/lists/*
  tar -C "$rootfs" -c . | "$ENGINE" import - "$BASE_IMAGE" >/dev/null
  rm -rf "$rootfs" "$rootfs.log"
}

# The CA bundle the build trusts for HTTPS (npm's registry, an https apt mirror): SITE_CA_BUNDLE when set, else the
# machine's own bundle. It reaches the Dockerfile as the build secret `site_ca` (docs/deploy.md), never a layer.
site_ca_bundle() {
  echo "${SITE_CA_BUNDLE:-/etc/ssl/certs/ca-certificates.crt}"
}

# podman on these sandboxes: the default OCI isolation needs cgroups v2 it does not get ("cgroups in hybrid mode
# not supported"); chroot isolation with cgroupfs builds the same image. --format docker: the OCI image format has
# no HEALTHCHECK, podman would drop it.
engine_build() {
  if [[ $ENGINE == podman ]]; then
    podman build --isolation=chroot --cgroup-manager=cgroupfs --format docker "$@"
  else
    docker build "$@"
  fi
}

pick_engine
