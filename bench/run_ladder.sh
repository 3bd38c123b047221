#!/usr/bin/env bash
# Measures the molecule ladder (gly … 1k4r_capsid) at densities 1 and 2 with three paths: lattice (refined), trace
# raw (refine=none) and trace refined. One ladder_bench process per row; every row is the median of RUNS runs (peak
# RSS: the first run). A row that fails prints as a row saying "failed" and why; the run goes on. Prints one Markdown
# table, then the trace/lattice time ratios and the issue's default rule (bench/bench_report.py, needs python3).
#
# Usage: bench/run_ladder.sh [RUNS] [MAX_ATOMS]          (`make bench` builds, then runs this)
# Environment, all optional:
#   BUILD_DIR      build tree with bin/ladder_bench (default: build)
#   TRACEMESH_MOLECULES_DIR  the ladder's PQR files (docs/benchmarks.md; default ../shared/molecules)
#   RUNS           runs per row (default 3)            MAX_ATOMS  skip molecules with more atoms
#   MOLECULES      names to keep, e.g. "gly fas2 mache" (default: the whole ladder)
#   DENSITIES      (default "1 2")                     PATHS      (default "lattice trace-raw trace-refined")
#   THREADS        threads per row, 0 = all cores (default 0)
#   ROW_TIMEOUT    seconds before a row is stopped and printed as failed (default 3600)
#   OUT_DIR        where ladder.md and ladder.jsonl are written (default: $BUILD_DIR/bench)
set -euo pipefail
# shellcheck source=bench/bench_lib.sh
source "$(dirname "$0")/bench_lib.sh"

runs=${1:-${RUNS:-3}}
max_atoms=${2:-${MAX_ATOMS:-}}
densities=${DENSITIES:-1 2}
paths=${PATHS:-lattice trace-raw trace-refined}
threads=${THREADS:-0}
out_dir=${OUT_DIR:-$build_dir/bench}
require_bench_bin
mkdir -p "$out_dir"
jsonl=$out_dir/ladder.jsonl
: >"$jsonl"

selected=()
for entry in "${ladder[@]}"; do
  file=${entry% *} atoms=${entry#* }
  [[ -n $max_atoms ]] && ((atoms > max_atoms)) && continue
  [[ -n ${MOLECULES:-} && " $MOLECULES " != *" $(molecule_name "$file") "* ]] && continue
  selected+=("$file")
done
if ((${#selected[@]} == 0)); then
  echo "run_ladder: no molecule left after MAX_ATOMS='$max_atoms' MOLECULES='${MOLECULES:-}'" >&2
  exit 2
fi

{
  shown_threads=$threads
  [[ $threads == 0 ]] && shown_threads="all ($(nproc))"
  echo "Machine: $(nproc) cores, $(free -g | awk '/Mem:/{print $2}') GiB; $(date -u +%Y-%m-%d);" \
       "commit $(bench_commit);" \
       "medians of $runs runs (peak RSS: the first); threads per row: $shown_threads"
  echo
  "$bench_bin" --header
  for file in "${selected[@]}"; do
    for density in $densities; do
      for path in $paths; do
        run_row "$file" "$density" "$path" "$threads" "$runs" "$jsonl"
      done
    done
  done
  echo
  if command -v python3 >/dev/null; then
    python3 "$bench_root/bench/bench_report.py" ladder-summary "$jsonl" \
      --full-ladder "$([[ ${#selected[@]} == "${#ladder[@]}" ]] && echo yes || echo no)"
  else
    echo "(python3 not found: no summary; the rows are in $jsonl)"
  fi
} | tee "$out_dir/ladder.md"
echo
echo "Written: $out_dir/ladder.md, $jsonl" >&2
