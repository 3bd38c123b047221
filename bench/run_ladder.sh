#!/usr/bin/env bash
# Meshes the whole molecule ladder at densities 1 and 2 and prints the benchmark table (Markdown).
# Usage: bench/run_ladder.sh [RUNS=3] [MAX_ATOMS]   (run `make build` first; `make bench` does both)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bin=${BUILD_DIR:-$root/build}/bin/ladder_bench
molecules=${MOLECULES_DIR:-$root/../shared/molecules}
runs=${1:-3}
ladder=(gly.pqr adp.pqr villin_1vii.pqr fas2.pqr mache.pqr achbp.pqr 3j6r_asu.pqr 1ihm_asu.pqr 2buk_12asu.pqr
        1k4r_5asu.pqr.gz 2buk_capsid.pqr.gz 1rb8_capsid.pqr.gz 1k4r_capsid.pqr.gz)
echo "Machine: $(nproc) cores, $(free -g | awk '/Mem:/{print $2}') GiB; $(date -u +%Y-%m-%d); medians of $runs runs"
echo
header=--header
for molecule in "${ladder[@]}"; do
  for density in 1 2; do
    "$bin" "$molecules/$molecule" "$density" "$runs" $header || echo "| $molecule | | $density | failed |"
    header=
  done
done
