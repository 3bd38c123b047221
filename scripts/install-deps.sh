#!/usr/bin/env bash
# Installs the Debian 12 packages tracemesh builds, tests and benchmarks with; does nothing when all are present.
# Usage: scripts/install-deps.sh [--bench-paper | --build-only | --image]
#   --bench-paper adds python3-matplotlib and python3-numpy for `make bench-paper`;
#   --build-only installs just what compiles tracemesh and tracemeshd without tests and benchmarks
#   (-DTRACEMESH_BUILD_TESTS=OFF -DTRACEMESH_BUILD_BENCH=OFF), node and the npm packages included (the web viewer
#   is bundled at build time): the build stage of docker/Dockerfile;
#   --image installs what `make image` and `make test-image` need: podman and debootstrap when no docker daemon
#   answers (scripts/container-engine.sh); curl, jq, nginx-light and openssl for tests/image/smoke_test.sh.
set -euo pipefail
# What compiling the libraries, tracemesh and tracemeshd needs (cmake/dependencies.cmake).
build_packages=(
  cmake g++ make pkg-config ca-certificates ccache
  libboost-dev nlohmann-json3-dev libdraco-dev libtinygltf-dev libspdlog-dev libfmt-dev libtbb-dev
  libssl-dev libcli11-dev zlib1g-dev libbrotli-dev gemmi-dev tao-pegtl-dev
  libhiredis-dev  # the Redis client of `tracemeshd --store redis://…` (server/redis/)
  dpkg-dev file   # dpkg-shlibdeps and file: `make package` computes the .deb's Depends from the programs
)
# The suite, the benchmarks, the fuzzers and the tools the tests call (draco_decoder, curl, wrk, nginx).
test_packages=(
  git curl draco libgtest-dev libgmock-dev libbenchmark-dev libcgal-dev libgmp-dev libmpfr-dev
  clang-14 libclang-rt-14-dev wrk nginx-light procps
  redis-server  # the suite starts its own redis-server on a free loopback port (tests/support/redis_process.hpp)
  chromium  # the web viewer's browser test (tests/node/web_viewer_test.mjs): headless, WebGL on SwiftShader
  debootstrap systemd man-db  # the package tests: a clean Debian root, systemd-analyze verify, the man pages
  # The Python package (python/, built by `make build`, not by `make run`) and its tests (tests/python/).
  python3-dev python3-numpy pybind11-dev python3-pytest
)
needs_node=true  # node, npm and `npm ci`: the viewer's bundle (every build) and the suite's checkers
packages=("${build_packages[@]}" "${test_packages[@]}")
case ${1:-} in
  --bench-paper) packages+=(python3 python3-matplotlib python3-numpy) ;;  # the plots of bench/bench_report.py
  --build-only) packages=("${build_packages[@]}") ;;
  --image)
    needs_node=false; packages=(curl jq nginx-light openssl)
    if ! docker info >/dev/null 2>&1; then packages+=(podman debootstrap); fi ;;
  "") ;;
  *) echo "install-deps: unknown option '$1' (--bench-paper, --build-only or --image)" >&2; exit 2 ;;
esac
missing=()
# node and npm (≥ 18): these machines have node 20 with its npm; a bare Debian 12 gets Debian's nodejs and npm.
if $needs_node && { ! command -v node >/dev/null || ! command -v npm >/dev/null; }; then missing+=(nodejs npm); fi
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "install-deps: installing ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The npm packages: with --build-only just what bundles the web viewer (package.json "dependencies": esbuild, three),
# otherwise also the suite's checkers ("devDependencies": glTF validator, OpenAPI lint, JSON-schema checks, the
# browser driver). Exactly package-lock.json, re-installed only when the lock file or the set asked for changed.
$needs_node || exit 0
repo=$(cd "$(dirname "$0")/.." && pwd)
npm_set=full; npm_flags=()
[[ ${1:-} == --build-only ]] && { npm_set=build; npm_flags=(--omit=dev); }
stamp="$repo/node_modules/.tracemesh-npm-set"
installed_set=$(cat "$stamp" 2>/dev/null || true)
# A full install serves a build-only request; anything else installs again.
if [[ ! -f $stamp || "$repo/package-lock.json" -nt $stamp || ( $installed_set != full && $installed_set != "$npm_set" ) ]]; then
  echo "install-deps: npm ci ${npm_flags[*]}"
  (cd "$repo" && npm ci --no-audit --no-fund --loglevel=error "${npm_flags[@]}")
  echo "$npm_set" > "$stamp"
fi
