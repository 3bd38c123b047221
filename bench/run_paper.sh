#!/usr/bin/env bash
# Reproduces the evaluation of TMSmesh (Chen & Lu, JCTC 2011) with tracemesh: measures every row it needs with
# ladder_bench (one process per row, medians of RUNS runs, peak RSS of the first) and writes bench/paper/report.md
# with its figures (bench/bench_report.py): the targets table, Table 2 side by side (1 and 2 threads), Figure 5 (edge
# ratio histograms), Figure 6 (area and volume against density) and the linear cost over the ladder (Fig. 3).
# A row that fails is recorded as failed (and listed in the report); the run goes on.
#
# Usage: bench/run_paper.sh          (`make bench-paper` builds, installs python3-matplotlib, then runs this)
# Environment, all optional:
#   BUILD_DIR, MOLECULES_DIR, ROW_TIMEOUT   as for bench/run_ladder.sh
#   RUNS             runs per timed row (default 3)
#   PAPER_MAX_ATOMS  skip molecules with more atoms, e.g. 20000 for a quick run (default: every molecule)
#   PAPER_DIR        where report.md and the figures go (default: bench/paper); the rows go to $PAPER_DIR/data/
#   RESUME=1         keep the rows already measured in $PAPER_DIR/data and measure only the missing ones
#   PYTHON           the interpreter with matplotlib (default: python3, else /usr/bin/python3)
set -euo pipefail
# shellcheck source=bench/bench_lib.sh
source "$(dirname "$0")/bench_lib.sh"

runs=${RUNS:-3}
max_atoms=${PAPER_MAX_ATOMS:-}
paper_dir=${PAPER_DIR:-$bench_root/bench/paper}
data=$paper_dir/data
require_bench_bin

python=${PYTHON:-}
if [[ -z $python ]]; then
  for candidate in python3 /usr/bin/python3; do
    if "$candidate" -c "import matplotlib" 2>/dev/null; then python=$candidate; break; fi
  done
fi
if [[ -z $python ]]; then
  echo "run_paper: no python3 with matplotlib (Debian: apt-get install python3-matplotlib, or PYTHON=...)" >&2
  exit 2
fi

mkdir -p "$data"
declare -A measured=()  # "molecule density path threads" of the rows already in rows.jsonl
if [[ ${RESUME:-0} == 1 && -f $data/done.txt ]]; then
  while read -r key; do measured[$key]=1; done <"$data/done.txt"
else
  : >"$data/rows.jsonl"
  : >"$data/done.txt"
  "$bench_bin" --header >"$data/rows.md"
  "$bench_bin" --header
fi

cpu=$(awk -F': *' '/^model name/{print $2; exit}' /proc/cpuinfo | tr -d "\"\\\\")
printf '{"cores":%s,"cpu":"%s","memory_gib":%s,"date":"%s","commit":"%s","runs":%s,"paper_max_atoms":%s}\n' \
  "$(nproc)" "${cpu:-unknown}" "$(awk '/MemTotal/{printf "%.0f", $2 / 1048576}' /proc/meminfo)" \
  "$(date -u +%Y-%m-%d)" "$(bench_commit)" "$runs" "${max_atoms:-null}" >"$data/meta.json"

# row NAME DENSITY PATH THREADS [RUNS]: measures one row unless it is filtered out or already measured.
row() {
  local name=$1 density=$2 path=$3 threads=$4 row_runs=${5:-$runs} file atoms key
  file=$(file_of "$name")
  atoms=$(atoms_of "$name")
  [[ -n $max_atoms ]] && ((atoms > max_atoms)) && return 0
  key="$name $density $path $threads"
  [[ -n ${measured[$key]:-} ]] && return 0
  run_row "$file" "$density" "$path" "$threads" "$row_runs" "$data/rows.jsonl" | tee -a "$data/rows.md"
  measured[$key]=1
  echo "$key" >>"$data/done.txt"
}
paths=(lattice trace-raw trace-refined)

# Figure 6: area and volume against density (small molecules).
for name in gly adp villin_1vii; do
  for density in 0.5 1 2 4 6 8 10; do
    for path in "${paths[@]}"; do row "$name" "$density" "$path" 2; done
  done
done
# Figure 5: edge-ratio histograms.
for name in fas2 mache; do
  for density in 2 10; do
    for path in "${paths[@]}"; do row "$name" "$density" "$path" 2; done
  done
done
# References for the targets: the lattice at 8 v/Å² (geometry and topology only, so one run).
for name in fas2 mache 2buk_12asu; do row "$name" 8 lattice 2 1; done
# The ladder at 1 and 2 v/Å² on 2 threads: linear cost, quality and certificate targets, Table 2's 2-thread rows.
for entry in "${ladder[@]}"; do
  for density in 1 2; do
    for path in "${paths[@]}"; do row "$(molecule_name "${entry% *}")" "$density" "$path" 2; done
  done
done
# Table 2 on one thread.
for name in fas2 mache 1k4r_5asu 2buk_capsid 1k4r_capsid; do
  for density in 1 2; do
    for path in "${paths[@]}"; do row "$name" "$density" "$path" 1; done
  done
done

"$python" "$bench_root/bench/bench_report.py" paper "$data" "$paper_dir"

# Where the trace path's topology differs from the lattice path's at 8 v/Å² on mache (README, "Deviations"): the
# meshes, then yz cross-sections through the thin tunnel neck both miss or get wrong and the void no line meets.
cli=$build_dir/bin/tracemesh
mache_pqr=$molecules_dir/$(file_of mache)
draw_topology() {  # the meshes (~25 MB) go to a temporary folder, not to $data
  local meshes status=0
  meshes=$(mktemp -d)
  "$cli" "$mache_pqr" --method trace --density 2 -o "$meshes/trace2.off" --report "$meshes/trace2.json" &&
    "$cli" "$mache_pqr" --method lattice --density 8 -o "$meshes/lattice8.off" &&
    "$python" "$bench_root/bench/paper/topology_figure.py" --pqr "$mache_pqr" --trace "$meshes/trace2.off" \
      --trace-report "$meshes/trace2.json" --lattice "$meshes/lattice8.off" --seed "tunnel neck":-0.3,11.31,8.93 \
      --title "mache at 2 v/Å²: a tunnel 0.17 Å wide that the trace path closes" \
      -o "$paper_dir/topology_mache.png" || status=1
  rm -rf "$meshes"
  return $status
}
if [[ -x $cli && -z ${measured["topology mache"]:-} ]]; then
  if draw_topology; then echo "topology mache" >>"$data/done.txt"; else echo "run_paper: topology_mache.png failed" >&2; fi
else
  echo "run_paper: $cli not built or already drawn; topology_mache.png not (re)drawn" >&2
fi
echo "Written: $paper_dir/report.md, $paper_dir/*.png; rows in $data/" >&2
