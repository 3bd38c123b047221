#!/usr/bin/env bash
# Installs the Debian 12 packages tracemesh builds, tests and benchmarks with; does nothing when all are present.
# Usage: scripts/install-deps.sh [--bench-paper]   (--bench-paper adds python3-matplotlib and python3-numpy for `make bench-paper`)
set -euo pipefail
packages=(
  cmake g++ make pkg-config git curl ca-certificates
  libboost-dev nlohmann-json3-dev libdraco-dev draco libspdlog-dev libfmt-dev libtbb-dev
  libgtest-dev libgmock-dev libbenchmark-dev libssl-dev libcli11-dev zlib1g-dev
  libcgal-dev libgmp-dev libmpfr-dev gemmi-dev tao-pegtl-dev
  clang-14 libclang-rt-14-dev wrk nginx-light procps
)
# `make bench-paper` only: the plots of bench/bench_report.py.
if [[ ${1:-} == --bench-paper ]]; then packages+=(python3 python3-matplotlib python3-numpy); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "install-deps: installing ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
