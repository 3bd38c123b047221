#!/usr/bin/env python3
"""Where the trace path's time goes, stage by stage (the project's issue 34).

Two tables, Markdown:

1. Wall seconds per stage (median of RUNS runs of `tracemesh FILE --report -`: trace, refined, THREADS threads), the
   line grids retried and the seconds spent on the failed attempts (the report's trace.grid_retries and
   timings.failed_attempts), the field evaluations of the trace (roots and traces) and their number per output
   vertex, for each molecule given
   (default: 2buk_capsid.pqr.gz 1k4r_capsid.pqr.gz from TRACEMESH_MOLECULES_DIR).
2. With --callgrind MOLECULE (a small one: callgrind runs ~50× slower): instructions per stage, load-independent
   (valgrind --tool=callgrind, one thread), from the inclusive cost of the function that runs each stage; the calls
   of gaussian_field's point evaluations by calling function (the field evaluations outside the root finder's own
   line sampling; through a field_neighbourhood or not); and, with --heaptrack as well, the calls to allocation functions per stage (heaptrack, same
   attribution: allocations made under each stage's function).

Environment: TRACEMESH (default build/bin/tracemesh), TRACEMESH_MOLECULES_DIR (default: as bench/bench_lib.sh),
RUNS (default 3), THREADS (default 2), TRACEMESH_BASELINE (optional: a second tracemesh binary, e.g. built at an
earlier commit; table 1 then has a row per binary and molecule, from runs interleaved baseline, tracemesh, baseline,
... so that a slow phase of a shared machine hits both alike).
Usage: python3 bench/stage_table.py [MOLECULE ...] [--callgrind MOLECULE [--heaptrack]]
  e.g. python3 bench/stage_table.py --callgrind mache.pqr      (table 2 only: no molecules given but mache)
"""
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_MOLECULES = ["2buk_capsid.pqr.gz", "1k4r_capsid.pqr.gz"]
# Stages as the report names them (core/progress.cpp), in pipeline order.
STAGES = ["culling", "roots", "tracing", "triangulating", "refining", "certifying"]
# The function whose inclusive cost is each stage's (core/mesher.cpp, core/trace/trace_mesher.cpp); triangulating is
# mesh_polygons without the roots and tracing it calls. The rest of the run (reading, building the fields, writing)
# is "other".
STAGE_FUNCTIONS = {
    "culling": "cull_blocks(",
    "roots": "find_all_line_roots(",
    "tracing": "trace_all_strips(",
    "polygons": "mesh_polygons(",
    "refining": "remesh_surface(",
    "certifying": "certify(",
}
# The field's point evaluations: gaussian_field's own, and those through a field_neighbourhood.
FIELD_FUNCTIONS = ["gaussian_field::value_and_gradient(", "gaussian_field::value(", "gaussian_field::probe(",
                   "gaussian_field::surface_distance(", "gaussian_field::project_to_surface(",
                   "field_neighbourhood::value_and_gradient("]


def molecule_path(name):
    if os.path.sep in name:
        return name
    directory = os.environ.get("TRACEMESH_MOLECULES_DIR", os.path.join(REPO, "..", "shared", "molecules"))
    return os.path.join(directory, name)


def tracemesh_command(binary, molecule, mesh, threads):
    return [binary, molecule_path(molecule), "-o", mesh, "--method", "trace", "--refine", "full",
            "--threads", str(threads), "--report", "-"]


def report_of(binary, molecule, threads, work):
    run = subprocess.run(tracemesh_command(binary, molecule, os.path.join(work, "mesh.off"), threads),
                         capture_output=True, text=True, check=False)
    if run.returncode != 0:
        raise RuntimeError(f"tracemesh {molecule}: {run.stderr.strip()}")
    return json.loads(run.stdout)


def build_label(binary):
    """What `binary --version` names it by: its engine and, where it says, its commit (else the binary's path)."""
    version = subprocess.run([binary, "--version"], capture_output=True, text=True, check=False).stdout
    engine = re.search(r"tracemesh-engine-\d+", version)
    commit = re.search(r"commit (\w+)", version)
    if not engine:
        return binary
    return engine.group(0) + (f" at {commit.group(1)}" if commit else "")


def interleaved_reports(binaries, molecule, runs, threads, work):
    """{binary: [report, ...]}: `runs` reports of each binary, run in turn (b1, b2, b1, b2, ...)."""
    reports = {binary: [] for binary in binaries}
    for _ in range(runs):
        for binary in binaries:
            reports[binary].append(report_of(binary, molecule, threads, work))
    return reports


def seconds_row(label, molecule, reports):
    med = {s: statistics.median(r["timings"].get(s, 0.0) for r in reports) for s in STAGES + ["total"]}
    last = reports[-1]
    evaluations = last["trace"]["field_evaluations"]
    failed = statistics.median(r["timings"].get("failed_attempts", 0.0) for r in reports)
    return (f"| {molecule} | {label} | {last['vertices']} | {last['trace'].get('grid_retries', 0)} | {failed:.2f} | " +
            " | ".join(f"{med[s]:.2f}" for s in STAGES) +
            f" | {med['total']:.2f} | {evaluations} | {evaluations / last['vertices']:.1f} |")


def seconds_table(binaries, molecules, runs, threads):
    print(f"Seconds per stage (wall, medians of {runs}" + (", interleaved" if len(binaries) > 1 else "") +
          f"; trace, refined, 1 v/Å², {threads} threads)\n")
    print("| molecule | build | vertices | grid retries | failed attempts | " + " | ".join(STAGES) +
          " | total | field evaluations | per vertex |")
    print("|---|---|---:|---:|---:|" + "---:|" * (len(STAGES) + 3))
    labels = {binary: build_label(binary) for binary in binaries}
    work = tempfile.mkdtemp(prefix="stage_table_")
    try:
        for molecule in molecules:
            reports = interleaved_reports(binaries, molecule, runs, threads, work)
            for binary in binaries:
                print(seconds_row(labels[binary], molecule, reports[binary]), flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print()


def inclusive_costs(annotated):
    """{function text: inclusive Ir} from callgrind_annotate --inclusive=yes output."""
    costs = {}
    for line in annotated.splitlines():
        m = re.match(r"\s*([\d,]+)\s+(?:\([^)]*\)\s+)?\S*?:(.+)$", line)
        if m:
            costs.setdefault(m.group(2).strip(), int(m.group(1).replace(",", "")))
    return costs


def cost_of(costs, needle):
    """Inclusive cost of the function whose name contains `needle` (the largest, if several do)."""
    found = [c for name, c in costs.items() if needle in name]
    return max(found) if found else 0


def stage_costs(costs, total):
    polygons = cost_of(costs, STAGE_FUNCTIONS["polygons"])
    out = {s: cost_of(costs, STAGE_FUNCTIONS[s]) for s in ["culling", "roots", "tracing", "refining", "certifying"]}
    out["triangulating"] = polygons - out["roots"] - out["tracing"]
    out["other"] = total - sum(out[s] for s in STAGES)
    return out


def field_calls(tree):
    """[(callee, caller, calls, instructions)] for the field's point evaluations, from callgrind_annotate
    --tree=caller."""
    rows, block = [], []
    for line in tree.splitlines() + [""]:
        if line.strip():
            block.append(line)
            continue
        callee = next((re.match(r"\s*[\d,]+\s+\([^)]*\)\s+\*\s+\S*?:(.+?) \[", l) for l in block if " * " in l), None)
        if callee and any(callee.group(1).startswith("tracemesh::" + f) for f in FIELD_FUNCTIONS):
            name = callee.group(1)
            for l in block:
                m = re.match(r"\s*([\d,]+)\s+\([^)]*\)\s+<\s+\S*?:(.+?)\s+\(([\d,]+)x\)", l)
                if m:
                    rows.append((name, m.group(2).strip(), int(m.group(3).replace(",", "")),
                                 int(m.group(1).replace(",", ""))))
        block = []
    return rows


def short(name, width=60):
    """A function's name without namespaces, arguments or templates: enough to tell the callers apart."""
    name = re.sub(r"tracemesh::|\(anonymous namespace\)::|detail::|std::", "", name)
    lambda_owner = re.search(r"([\w:]+)\([^()]*\)(?:\s*const)?::\{lambda", name)
    if lambda_owner:
        return lambda_owner.group(1) + " (lambda)"
    depth, out = 0, ""
    for ch in name:  # drop template arguments and the argument list
        if ch in "<(":
            depth += 1
        elif ch in ">)":
            depth -= 1
        elif depth == 0:
            out += ch
    out = out.strip()
    return out if len(out) <= width else out[: width - 1] + "…"


def heaptrack_stage_allocations(binary, molecule, work):
    """Calls to allocation functions made under each stage's function (heaptrack, one thread)."""
    base = os.path.join(work, "heaptrack")
    subprocess.run(["heaptrack", "-o", base] + tracemesh_command(binary, molecule, os.path.join(work, "h.off"), 1),
                   capture_output=True, check=True)
    data = next(os.path.join(work, f) for f in os.listdir(work) if f.startswith("heaptrack."))
    printed = subprocess.run(["heaptrack_print", "-f", data, "--print-allocators", "1", "-n", "100000",
                              "--print-peaks", "0", "--print-leaks", "0", "--print-temporary", "0",
                              "--merge-backtraces", "0"],  # no --print-histogram: its argument is a file to write
                             capture_output=True, text=True, check=True).stdout
    total = re.search(r"calls to allocation functions: (\d+)", printed)
    per_stage = {s: 0 for s in STAGE_FUNCTIONS}
    # Each allocation site: "N calls with M peak ... from:" then its backtrace, indented; attribute it to the
    # outermost stage function on the stack (a stage's own callees never include another stage's function).
    for site in re.split(r"\n(?=\S)", printed):
        m = re.match(r"(\d+) calls", site)
        if not m:
            continue
        for stage, needle in STAGE_FUNCTIONS.items():
            if needle in site:
                per_stage[stage] += int(m.group(1))
                break
    per_stage["triangulating"] = per_stage.pop("polygons")  # sites under roots or tracing were counted there
    total_calls = int(total.group(1)) if total else 0
    per_stage["other"] = total_calls - sum(per_stage[s] for s in STAGES)
    return total_calls, per_stage


def callgrind_table(binary, molecule, with_heaptrack):
    work = tempfile.mkdtemp(prefix="stage_table_cg_")
    try:
        out = os.path.join(work, "callgrind.out")
        run = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}"] +
                             tracemesh_command(binary, molecule, os.path.join(work, "cg.off"), 1),
                             capture_output=True, text=True, check=False)
        if run.returncode != 0:
            raise RuntimeError(f"callgrind: {run.stderr.strip()[-400:]}")
        report = json.loads(run.stdout)
        annotate = ["callgrind_annotate", "--threshold=100"]
        inclusive = subprocess.run(annotate + ["--inclusive=yes", out], capture_output=True, text=True,
                                   check=True).stdout
        total = int(re.search(r"([\d,]+)\s+\(100\.0%\)\s+PROGRAM TOTALS", inclusive).group(1).replace(",", ""))
        stages = stage_costs(inclusive_costs(inclusive), total)
        tree = subprocess.run(annotate + ["--tree=caller", out], capture_output=True, text=True, check=True).stdout
        allocations = heaptrack_stage_allocations(binary, molecule, work) if with_heaptrack else None
    finally:
        shutil.rmtree(work, ignore_errors=True)
    vertices = report["vertices"]
    print(f"Instructions per stage, {molecule} (callgrind, 1 thread; {vertices} vertices; trace field evaluations "
          f"{report['trace']['field_evaluations']}, {report['trace']['field_evaluations_per_vertex']:.1f} per vertex)\n")
    header = "| stage | instructions (10⁶) | share |" + (" allocations |" if allocations else "")
    print(header)
    print("|---|---:|---:|" + ("---:|" if allocations else ""))
    for s in STAGES + ["other"]:
        row = f"| {s} | {stages[s] / 1e6:.1f} | {100 * stages[s] / total:.1f}% |"
        if allocations:
            row += f" {allocations[1].get(s, '—')} |"
        print(row)
    print(f"| total | {total / 1e6:.1f} | 100% |" + (f" {allocations[0]} |" if allocations else ""))
    print("\nPoint evaluations of the field by caller (the root finder's line samples are not among them; a "
          "neighbourhood's include its gathers)\n")
    print("| evaluation | caller | calls | per vertex | instructions (10⁶) | per call |")
    print("|---|---|---:|---:|---:|---:|")
    for callee, caller, calls, cost in sorted(field_calls(tree), key=lambda r: -r[2]):
        print(f"| {short(callee, 40)} | {short(caller)} | {calls} | {calls / vertices:.2f} | {cost / 1e6:.1f} | "
              f"{cost / calls:.0f} |")
    print()


def main():
    args = sys.argv[1:]
    callgrind_molecule, with_heaptrack = None, False
    if "--heaptrack" in args:
        args.remove("--heaptrack")
        with_heaptrack = True
    if "--callgrind" in args:
        at = args.index("--callgrind")
        if at + 1 >= len(args):
            print("stage_table: --callgrind needs a molecule", file=sys.stderr)
            return 2
        callgrind_molecule = args[at + 1]
        del args[at:at + 2]
    binary = os.environ.get("TRACEMESH", os.path.join(REPO, "build", "bin", "tracemesh"))
    if not os.access(binary, os.X_OK):
        print(f"stage_table: {binary} not found; build it or set TRACEMESH", file=sys.stderr)
        return 2
    baseline = os.environ.get("TRACEMESH_BASELINE")
    if baseline and not os.access(baseline, os.X_OK):
        print(f"stage_table: TRACEMESH_BASELINE={baseline} is not an executable", file=sys.stderr)
        return 2
    runs = int(os.environ.get("RUNS", "3"))
    threads = int(os.environ.get("THREADS", "2"))
    molecules = args or ([] if callgrind_molecule else DEFAULT_MOLECULES)
    try:
        if molecules:
            seconds_table([baseline, binary] if baseline else [binary], molecules, runs, threads)
        if callgrind_molecule:
            callgrind_table(binary, callgrind_molecule, with_heaptrack)
    except (RuntimeError, OSError, subprocess.CalledProcessError) as error:
        print(f"stage_table: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
