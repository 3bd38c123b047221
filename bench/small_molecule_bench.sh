#!/usr/bin/env bash
# Issue 34: small jobs end to end. Times whole `tracemesh MOLECULE -o OUT.off` processes (start-up, reading,
# meshing with the defaults, encoding, writing) on the small molecules of tests/data/molecules, for one binary or
# for two side by side (a baseline and a candidate, run alternately so that a change of machine load hits both),
# and prints a Markdown table of the medians, wall and CPU milliseconds, and whether the two wrote the same bytes.
# Usage: bash bench/small_molecule_bench.sh [AFTER [BEFORE]]   (default AFTER: build/bin/tracemesh)
# Knobs: RUNS (11 per binary and molecule), MOLECULES ("fas2 gly adp villin_1vii mache"), ARGS (extra tracemesh
# arguments, e.g. "--density 2 --refine none"), OUT_DIR (where the meshes go, default a fresh temporary directory:
# the write, its fsync included, is part of the time, so put it on the file system that matters).
# INSTRUCTIONS=1 adds the user-space instructions of one run per binary and molecule on 1 thread, counted by
# valgrind's cachegrind (about 50 times slower): the same count however loaded the machine is, for comparing two
# binaries where timings cannot.
# Timings are only meaningful on a quiet machine; the table says how loaded it was.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
AFTER=${1:-$ROOT/build/bin/tracemesh}
BEFORE=${2:-}
RUNS=${RUNS:-11}
MOLECULES=${MOLECULES:-fas2 gly adp villin_1vii mache}
read -r -a EXTRA <<< "${ARGS:-}"

if [ "${INSTRUCTIONS:-0}" = 1 ]; then
  command -v valgrind > /dev/null || { echo "small_molecule_bench: INSTRUCTIONS=1 needs valgrind" >&2; exit 1; }
fi
for binary in "$AFTER" ${BEFORE:+"$BEFORE"}; do
  [ -x "$binary" ] || { echo "small_molecule_bench: $binary is not an executable" >&2; exit 1; }
done
WORK=${OUT_DIR:-$(mktemp -d)}
[ -n "${OUT_DIR:-}" ] || trap 'rm -rf "$WORK"' EXIT

# timed BINARY INPUT OUTPUT: "wall cpu" milliseconds of one run, CPU being user + system time of all its threads
# (fails the script when tracemesh fails). CPU time is the steadier of the two on a loaded machine.
timed() {
  python3 - "$@" "${EXTRA[@]}" << 'PYTHON'
import os, subprocess, sys, time
command = [sys.argv[1], sys.argv[2], "-o", sys.argv[3]] + sys.argv[4:]
start = time.perf_counter()
process = subprocess.Popen(command)
_, status, usage = os.wait4(process.pid, 0)
wall = time.perf_counter() - start
if os.waitstatus_to_exitcode(status) != 0:
    sys.exit("small_molecule_bench: %s failed" % " ".join(command))
print("%.3f %.3f" % (1000 * wall, 1000 * (usage.ru_utime + usage.ru_stime)))
PYTHON
}

# instructions BINARY INPUT OUTPUT: millions of instructions of one run on 1 thread.
instructions() {
  valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null "$1" "$2" -o "$3" "${EXTRA[@]}" \
    --threads 1 2>&1 | awk '/I +refs:/ { gsub(",", "", $NF); printf "%.1f\n", $NF / 1e6 }'
}

median() { python3 -c 'import statistics, sys; print("%.1f" % statistics.median(float(x) for x in sys.argv[1:]))' "$@"; }

echo "runs: $RUNS per binary and molecule, alternating; arguments: ${ARGS:-(defaults)}; $(nproc) cores;" \
  "load average at the start: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
header="| molecule | atoms | wall ms | CPU ms |" rule="|---|---:|---:|---:|"
if [ -n "$BEFORE" ]; then
  header="| molecule | atoms | before wall ms | after wall ms | after ÷ before | before CPU ms | after CPU ms | after ÷ before | same bytes |"
  rule="|---|---:|---:|---:|---:|---:|---:|---:|---|"
fi
if [ "${INSTRUCTIONS:-0}" = 1 ]; then
  if [ -n "$BEFORE" ]; then
    header+=" before M instructions | after M instructions | after ÷ before |" rule+="---:|---:|---:|"
  else
    header+=" M instructions |" rule+="---:|"
  fi
fi
echo "$header"
echo "$rule"
ratio() { python3 -c "print('%.2f' % ($2 / $1))"; }
for name in $MOLECULES; do
  input=$ROOT/tests/data/molecules/$name.pqr
  [ -f "$input" ] || { echo "small_molecule_bench: no $input" >&2; exit 1; }
  atoms=$(grep -cE '^(ATOM|HETATM)' "$input")
  after_wall=() after_cpu=() before_wall=() before_cpu=()
  for _ in $(seq "$RUNS"); do
    run=$(timed "$AFTER" "$input" "$WORK/$name.after.off")
    after_wall+=("${run% *}") after_cpu+=("${run#* }")
    [ -n "$BEFORE" ] || continue
    run=$(timed "$BEFORE" "$input" "$WORK/$name.before.off")
    before_wall+=("${run% *}") before_cpu+=("${run#* }")
  done
  if [ -n "$BEFORE" ]; then
    bw=$(median "${before_wall[@]}") aw=$(median "${after_wall[@]}")
    bc=$(median "${before_cpu[@]}") ac=$(median "${after_cpu[@]}")
    same=$(cmp -s "$WORK/$name.before.off" "$WORK/$name.after.off" && echo yes || echo NO)
    row="| $name | $atoms | $bw | $aw | $(ratio "$bw" "$aw") | $bc | $ac | $(ratio "$bc" "$ac") | $same |"
    if [ "${INSTRUCTIONS:-0}" = 1 ]; then
      bi=$(instructions "$BEFORE" "$input" "$WORK/$name.before.off")
      ai=$(instructions "$AFTER" "$input" "$WORK/$name.after.off")
      row+=" $bi | $ai | $(ratio "$bi" "$ai") |"
    fi
  else
    row="| $name | $atoms | $(median "${after_wall[@]}") | $(median "${after_cpu[@]}") |"
    [ "${INSTRUCTIONS:-0}" = 1 ] && row+=" $(instructions "$AFTER" "$input" "$WORK/$name.after.off") |"
  fi
  echo "$row"
done
echo
echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
