#!/usr/bin/env bash
# Installs the Debian 12 packages tracemesh builds, tests and benchmarks with; does nothing when all are present.
# Usage: scripts/install-deps.sh [--bench-paper]   (--bench-paper adds python3-matplotlib and python3-numpy for `make bench-paper`)
set -euo pipefail
packages=(
  cmake g++ make pkg-config git curl ca-certificates
  libboost-dev nlohmann-json3-dev libdraco-dev draco libtinygltf-dev libspdlog-dev libfmt-dev libtbb-dev
  libgtest-dev libgmock-dev libbenchmark-dev libssl-dev libcli11-dev zlib1g-dev libbrotli-dev
  libcgal-dev libgmp-dev libmpfr-dev gemmi-dev tao-pegtl-dev
  clang-14 libclang-rt-14-dev wrk nginx-light procps
)
# `make bench-paper` only: the plots of bench/bench_report.py.
if [[ ${1:-} == --bench-paper ]]; then packages+=(python3 python3-matplotlib python3-numpy); fi
missing=()
# node and npm (≥ 18): these machines have node 20 with its npm; a bare Debian 12 gets Debian's nodejs and npm.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then missing+=(nodejs npm); fi
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "install-deps: installing ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The npm packages of the suite's checkers (glTF validator, OpenAPI lint, JSON-schema checks) and later the web
# viewer's build: exactly package-lock.json, re-installed only when the lock file changed since the last install.
repo=$(cd "$(dirname "$0")/.." && pwd)
stamp="$repo/node_modules/.package-lock.json"
if [[ ! -f $stamp || "$repo/package-lock.json" -nt $stamp ]]; then
  echo "install-deps: npm ci"
  (cd "$repo" && npm ci --no-audit --no-fund --loglevel=error)
fi
