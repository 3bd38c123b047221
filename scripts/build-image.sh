#!/usr/bin/env bash
# `make image`: builds docker/Dockerfile as IMAGE (default localhost/tracemesh:latest) with docker or podman
# (scripts/container-engine.sh picks; ENGINE=docker|podman overrides). BUILD_JOBS: compile jobs inside (2).
# Behind a TLS-inspecting proxy: SITE_CA_BUNDLE=/path/to/bundle.pem (default: this machine's bundle) is given to the
# build as the secret `site_ca`. With a local Debian mirror: APT_MIRROR=http://mirror.example/debian.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
image=${1:-localhost/tracemesh:latest}
# shellcheck source=container-engine.sh
. "$repo/scripts/container-engine.sh"
ensure_base_image
started=$(date +%s)
build_args=(--build-arg "BUILD_JOBS=${BUILD_JOBS:-2}")
commit=$(git -C "$repo" rev-parse --short HEAD 2>/dev/null || true)
[[ -n $commit ]] && build_args+=(--build-arg "TRACEMESH_COMMIT=$commit")
[[ -n ${APT_MIRROR:-} ]] && build_args+=(--build-arg "APT_MIRROR=$APT_MIRROR")
ca=$(site_ca_bundle)
if [[ -f $ca ]]; then build_args+=(--secret "id=site_ca,src=$ca"); fi
engine_build "${build_args[@]}" -f "$repo/docker/Dockerfile" -t "$image" "$repo"
echo "image: built $image with $ENGINE in $(($(date +%s) - started)) s; $("$ENGINE" image inspect --format '{{.Size}}' "$image" | awk '{ printf "%.0f MB", $1 / 1e6 }')"
