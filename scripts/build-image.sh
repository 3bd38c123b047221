#!/usr/bin/env bash
# `make image`: builds docker/Dockerfile as IMAGE (default localhost/tracemesh:latest) with docker or podman
# (scripts/container-engine.sh picks; ENGINE=docker|podman overrides). BUILD_JOBS: compile jobs inside (2).
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
image=${1:-localhost/tracemesh:latest}
# shellcheck source=container-engine.sh
. "$repo/scripts/container-engine.sh"
ensure_base_image
started=$(date +%s)
engine_build --build-arg "BUILD_JOBS=${BUILD_JOBS:-2}" -f "$repo/docker/Dockerfile" -t "$image" "$repo"
echo "image: built $image with $ENGINE in $(($(date +%s) - started)) s; $("$ENGINE" image inspect --format '{{.Size}}' "$image" | awk '{ printf "%.0f MB", $1 / 1e6 }')"
