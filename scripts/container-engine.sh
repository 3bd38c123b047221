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

# A registry-less machine cannot pull the base: build the same Debian 12 minbase with debootstrap and tag it with
# the name the Dockerfile asks for, so the Dockerfile stays the one a user builds anywhere.
ensure_base_image() {
  if "$ENGINE" image inspect "$BASE_IMAGE" >/dev/null 2>&1; then return; fi
  if "$ENGINE" pull -q "$BASE_IMAGE" >/dev/null 2>&1; then return; fi
  if ! command -v debootstrap >/dev/null; then
    echo "image: cannot pull $BASE_IMAGE and debootstrap is missing (apt-get install debootstrap)" >&2
    exit 1
  fi
  echo "image: $BASE_IMAGE cannot be pulled; building it with debootstrap"
  local rootfs
  rootfs=$(mktemp -d /tmp/tracemesh-base.XXXXXX)
  debootstrap --variant=minbase bookworm "$rootfs" http://deb.debian.org/debian >"$rootfs.log" 2>&1 \
    || { echo "image: debootstrap failed, see $rootfs.log" >&2; exit 1; }
  # Like the published slim image: no downloaded .debs, no package lists.
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/cache/apt/*.bin "$rootfs"/var/lib/apt/lists/*
  tar -C "$rootfs" -c . | "$ENGINE" import - "$BASE_IMAGE" >/dev/null
  rm -rf "$rootfs" "$rootfs.log"
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
