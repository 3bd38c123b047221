# shellcheck shell=bash
# Shared by bench/run_ladder.sh and bench/run_paper.sh (sourced, not run): the molecule ladder, the paths, and
# run_row, which measures one row in its own ladder_bench process and always prints a row, even when the process
# crashed or timed out.
#
# Reads: BUILD_DIR (default: build, relative to the current directory or to the repository), MOLECULES_DIR,
# ROW_TIMEOUT (seconds per row, default 3600).

bench_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=${BUILD_DIR:-build}
if [[ $build_dir != /* ]]; then
  if [[ -d $build_dir ]]; then build_dir=$(cd "$build_dir" && pwd); else build_dir=$bench_root/$build_dir; fi
fi
bench_bin=$build_dir/bin/ladder_bench
molecules_dir=${TRACEMESH_MOLECULES_DIR:-$bench_root/../shared/molecules}
[[ -d $molecules_dir ]] && molecules_dir=$(cd "$molecules_dir" && pwd)
row_timeout=${ROW_TIMEOUT:-3600}

# The ladder, smallest first: "file atoms" (atom counts written out, so filters need no reading).
ladder=(
  "gly.pqr 7" "adp.pqr 39" "villin_1vii.pqr 596" "fas2.pqr 906" "mache.pqr 8279" "achbp.pqr 16090"
  "3j6r_asu.pqr 17214" "1ihm_asu.pqr 22281" "2buk_12asu.pqr 34284" "1k4r_5asu.pqr.gz 90180"
  "2buk_capsid.pqr.gz 171420" "1rb8_capsid.pqr.gz 589680" "1k4r_capsid.pqr.gz 1082160"
)

require_bench_bin() {
  if [[ ! -x $bench_bin ]]; then
    echo "bench: $bench_bin not found; build it first (make build, or: cmake --build DIR --target ladder_bench)" >&2
    exit 2
  fi
}

# bench_commit: the checked-out commit, and whether the tree has changes on top of it
bench_commit() {
  local commit
  commit=$(git -C "$bench_root" rev-parse --short HEAD 2>/dev/null || echo unknown)
  git -C "$bench_root" diff --quiet HEAD 2>/dev/null || commit="$commit with uncommitted changes"
  echo "$commit"
}

# molecule_name FILE: gly.pqr / 1k4r_capsid.pqr.gz → gly / 1k4r_capsid
molecule_name() { local name=${1%.gz}; echo "${name%.pqr}"; }

# atoms_of NAME: the ladder's atom count for a molecule name or file (empty when not in the ladder)
atoms_of() {
  local entry
  for entry in "${ladder[@]}"; do
    if [[ $(molecule_name "${entry% *}") == "$(molecule_name "$1")" ]]; then echo "${entry#* }"; return; fi
  done
}

# file_of NAME: the ladder's file for a molecule name
file_of() {
  local entry
  for entry in "${ladder[@]}"; do
    if [[ $(molecule_name "${entry% *}") == "$1" ]]; then echo "${entry% *}"; return; fi
  done
}

# path_flags PATH: ladder_bench flags of a path id (lattice, lattice-raw, trace-raw, trace-refined)
path_flags() {
  case $1 in
    lattice) echo "--method lattice --refine full" ;;
    lattice-raw) echo "--method lattice --refine none" ;;
    trace-raw) echo "--method trace --refine none" ;;
    trace-refined) echo "--method trace --refine full" ;;
    *) echo "bench: unknown path '$1' (lattice, lattice-raw, trace-raw, trace-refined)" >&2; return 1 ;;
  esac
}

# path_label PATH: the label ladder_bench prints for it
path_label() {
  case $1 in
    lattice) echo "lattice refined" ;;
    *) echo "${1/-/ }" ;;
  esac
}

# run_row FILE DENSITY PATH THREADS RUNS JSONL: prints one Markdown row and appends one JSON line to JSONL.
# ladder_bench prints its own row, failed or not; when it dies (signal, timeout) this prints one that says so.
run_row() {
  local file=$1 density=$2 path=$3 threads=$4 runs=$5 jsonl=$6 flags rc=0 why
  flags=$(path_flags "$path") || return 0
  # shellcheck disable=SC2086  # flags are words
  timeout --kill-after=30 "$row_timeout" "$bench_bin" "$molecules_dir/$file" "$density" --runs "$runs" $flags \
    --threads "$threads" --json "$jsonl" || rc=$?
  ((rc == 0 || rc == 1)) && return 0
  if ((rc == 124)); then why="timed out after $row_timeout s"
  elif ((rc > 128)); then why="crashed: $(kill -l $((rc - 128)) 2>/dev/null || echo "signal $((rc - 128))")"
  else why="ladder_bench exit status $rc"
  fi
  local shown_threads=$threads atoms
  ((threads == 0)) && shown_threads=$(nproc)
  atoms=$(atoms_of "$file")
  printf '| %s | %s | %s | %s | %s | failed: %s |%s\n' "$file" "$atoms" "$density" "$(path_label "$path")" \
    "$shown_threads" "$why" "$(printf ' |%.0s' {1..18})"
  printf '{"molecule":"%s","file":"%s","atoms":%s,"density":%s,"path":"%s","threads":%s,"runs":%s,' \
    "$file" "$molecules_dir/$file" "${atoms:-0}" "$density" "$(path_label "$path")" "$shown_threads" "$runs" >>"$jsonl"
  printf '"status":"failed","error":"%s"}\n' "$why" >>"$jsonl"
}
