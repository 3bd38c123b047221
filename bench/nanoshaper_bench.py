#!/usr/bin/env python3
"""tracemesh against NanoShaper's Blobby surface at the same output size (the project's issue 34).

NanoShaper 1.5's Blobby surface is the level set exp(B·(|x−c|²/r² − 1)) summed over atoms = 1: tracemesh's φ with
d = B = −1 and t0 = 1 (its defaults). NanoShaper samples it on a grid of Grid_scale points per Å and triangulates
that grid; its vertex count grows as Grid_scale². For each molecule the bench times RUNS runs of each program,
interleaved (tracemesh, NanoShaper, tracemesh, ...: a slow phase of a shared machine hits both alike); after
tracemesh's first run (trace, refined, the default 1 vertex/Å²) it searches the Grid_scale at which NanoShaper's
vertex count is within MATCH_TOLERANCE of tracemesh's (the run at the chosen scale is NanoShaper's first sample, the
other tries are not timed). It prints one Markdown table: medians of wall and CPU seconds, peak RSS, vertex counts and
the wall-time ratio. NanoShaper's mesh is its Blobby triangulation (Root_FileName + "blobby.off").

Environment:
  NANOSHAPER               the NanoShaper binary (without it the bench says so and exits 0: nothing measured)
  TRACEMESH                the tracemesh binary (default: build/bin/tracemesh of the repository)
  TRACEMESH_BASELINE       optional: a second tracemesh binary (e.g. built at an earlier commit), run interleaved
                           with the others and given its own columns: vertices, wall, wall ratio to NanoShaper,
                           CPU, peak RSS (a before/after table from one set of runs)
  TRACEMESH_MOLECULES_DIR  where the large molecules are (default: as bench/bench_lib.sh)
  RUNS                     timed runs per program and molecule (default 3)
  THREADS                  threads of both programs (default 2)
Usage: python3 bench/nanoshaper_bench.py [MOLECULE ...]   (default: mache.pqr 2buk_capsid.pqr.gz 1k4r_capsid.pqr.gz)
"""
import gzip
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_MOLECULES = ["mache.pqr", "2buk_capsid.pqr.gz", "1k4r_capsid.pqr.gz"]
# NanoShaper's vertex count must be within this fraction of tracemesh's.
MATCH_TOLERANCE = 0.10
# The first Grid_scale tried: about tracemesh's 1 vertex/Å² on proteins.
FIRST_GRID_SCALE = 0.8
MAX_CALIBRATION_RUNS = 6


def molecules_dir():
    # The same default as bench/bench_lib.sh.
    return os.environ.get("TRACEMESH_MOLECULES_DIR", os.path.join(REPO, "..", "shared", "molecules"))


def open_text(path):
    return gzip.open(path, "rt", encoding="ascii") if path.endswith(".gz") else open(path, encoding="ascii")


def pqr_to_xyzr(pqr_path, xyzr_path):
    """Writes the atoms of a PQR file as x y z r lines; returns how many. Atoms of radius 0 contribute nothing to φ
    (tracemesh skips them) and would divide by zero in NanoShaper's kernel: they are left out."""
    count = 0
    with open_text(pqr_path) as source, open(xyzr_path, "w", encoding="ascii") as out:
        for line in source:
            if not line.startswith(("ATOM", "HETATM")):
                continue
            fields = line.split()
            x, y, z, radius = fields[-5], fields[-4], fields[-3], fields[-1]
            if float(radius) <= 0:
                continue
            out.write(f"{x} {y} {z} {radius}\n")
            count += 1
    return count


def off_counts(path):
    """(vertices, triangles) from an OFF file's header."""
    with open(path, encoding="ascii", errors="replace") as f:
        words = []
        for line in f:
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            words.extend(line.split())
            if len(words) >= 4:
                break
    if not words or words[0] != "OFF":
        raise RuntimeError(f"{path}: not an OFF file")
    return int(words[1]), int(words[2])


def timed_run(command, cwd):
    """Runs a command; returns (wall s, CPU s, peak RSS MiB) from its own rusage. Raises on failure."""
    start = time.perf_counter()
    with open(os.path.join(cwd, "output.log"), "wb") as log:
        process = subprocess.Popen(command, cwd=cwd, stdout=log, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - start
    process.returncode = os.waitstatus_to_exitcode(status)
    if process.returncode != 0:
        with open(os.path.join(cwd, "output.log"), encoding="utf-8", errors="replace") as log:
            tail = log.read()[-400:]
        raise RuntimeError(f"{command[0]} exited with {process.returncode}: {tail}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


NANOSHAPER_PRM = """\
Operative_Mode = normal
Surface = blobby
Blobbyness = -1
Grid_scale = {grid_scale}
Grid_perfil = 80.0
XYZR_FileName = {xyzr}
Number_thread = {threads}
Build_epsilon_maps = false
Build_status_map = false
Triangulation = false
Smooth_Mesh = false
Save_Mesh_MSMS_Format = false
Compute_Vertex_Normals = false
Vertex_Atom_Info = false
Cavity_Detection_Filling = false
Root_FileName = ns_
Patch_Based_Algorithm = false
"""


def run_nanoshaper(binary, xyzr, grid_scale, threads, work):
    """One NanoShaper run in `work`: (wall, CPU, RSS, vertices). The Blobby surface is written as ns_blobby.off
    (Root_FileName + "blobby.off": the grid's triangulation at level 1, before NanoShaper's own later passes)."""
    with open(os.path.join(work, "surface.prm"), "w", encoding="ascii") as f:
        f.write(NANOSHAPER_PRM.format(grid_scale=f"{grid_scale:.4f}", xyzr=xyzr, threads=threads))
    mesh = os.path.join(work, "ns_blobby.off")
    if os.path.exists(mesh):
        os.remove(mesh)
    wall, cpu, rss = timed_run([binary, "surface.prm"], work)
    return wall, cpu, rss, off_counts(mesh)[0]


def run_tracemesh(binary, molecule, threads, work):
    """One tracemesh run (trace, refined, its default density): (wall, CPU, RSS, vertices)."""
    mesh = os.path.join(work, "tracemesh.off")
    wall, cpu, rss = timed_run(
        [binary, molecule, "-o", mesh, "--method", "trace", "--refine", "full", "--threads", str(threads)], work)
    return wall, cpu, rss, off_counts(mesh)[0]


def calibrate_grid_scale(binary, xyzr, threads, work, target):
    """The Grid_scale at which NanoShaper's vertex count is within MATCH_TOLERANCE of `target` (vertices ∝ scale²),
    and the run made at it; the closest found if none is."""
    scale, best = FIRST_GRID_SCALE, None
    for _ in range(MAX_CALIBRATION_RUNS):
        run = run_nanoshaper(binary, xyzr, scale, threads, work)
        error = abs(run[3] - target) / target
        if best is None or error < best[2]:
            best = (scale, run, error)
        if error <= MATCH_TOLERANCE:
            break
        scale *= (target / run[3]) ** 0.5
    return best[0], best[1]


def median(values):
    return statistics.median(values)


def measure(molecule, nanoshaper, tracemesh, baseline, runs, threads):
    """Medians of `runs` runs of each program, interleaved. tracemesh's first run gives the vertex count NanoShaper is
    calibrated to; the calibration's run at the chosen Grid_scale is NanoShaper's first sample."""
    path = os.path.join(molecules_dir(), molecule)
    if not os.path.exists(path):
        raise RuntimeError(f"{path} not found (set TRACEMESH_MOLECULES_DIR)")
    work = tempfile.mkdtemp(prefix="nanoshaper_bench_")
    try:
        xyzr = os.path.join(work, "molecule.xyzr")
        atoms = pqr_to_xyzr(path, xyzr)
        tm, ns, base = [], [], []
        grid_scale = None
        for _ in range(runs):
            tm.append(run_tracemesh(tracemesh, path, threads, work))
            if baseline:
                base.append(run_tracemesh(baseline, path, threads, work))
            if grid_scale is None:
                grid_scale, first = calibrate_grid_scale(nanoshaper, xyzr, threads, work, tm[0][3])
                ns.append(first)
            else:
                ns.append(run_nanoshaper(nanoshaper, xyzr, grid_scale, threads, work))
        summary = lambda samples: [median([r[k] for r in samples]) for k in range(3)] + [samples[-1][3]]
        return {"molecule": molecule, "atoms": atoms, "grid_scale": grid_scale, "ns": summary(ns), "tm": summary(tm),
                "base": summary(base) if base else None}
    finally:
        shutil.rmtree(work, ignore_errors=True)


def main():
    nanoshaper = os.environ.get("NANOSHAPER")
    if not nanoshaper:
        print("nanoshaper_bench: skipped, NANOSHAPER is not set (the path of a NanoShaper 1.5 binary)", file=sys.stderr)
        return 0
    if not os.access(nanoshaper, os.X_OK):
        print(f"nanoshaper_bench: NANOSHAPER={nanoshaper} is not an executable", file=sys.stderr)
        return 2
    tracemesh = os.environ.get("TRACEMESH", os.path.join(REPO, "build", "bin", "tracemesh"))
    if not os.access(tracemesh, os.X_OK):
        print(f"nanoshaper_bench: {tracemesh} not found; build it or set TRACEMESH", file=sys.stderr)
        return 2
    baseline = os.environ.get("TRACEMESH_BASELINE")
    if baseline and not os.access(baseline, os.X_OK):
        print(f"nanoshaper_bench: TRACEMESH_BASELINE={baseline} is not an executable", file=sys.stderr)
        return 2
    runs = int(os.environ.get("RUNS", "3"))
    threads = int(os.environ.get("THREADS", "2"))
    molecules = sys.argv[1:] or DEFAULT_MOLECULES
    print(f"tracemesh (trace, refined, 1 v/Å², {threads} threads) vs NanoShaper Blobby (B = −1, {threads} threads); "
          f"medians of {runs} interleaved runs\n")
    base_header = (" TM baseline vertices | TM baseline wall s | baseline/NS wall | TM baseline CPU s |"
                   " TM baseline peak RSS MiB |") if baseline else ""
    print("| molecule | atoms | NS Grid_scale | NS vertices | TM vertices | NS wall s | TM wall s | TM/NS wall |" +
          base_header + " NS CPU s | TM CPU s | NS peak RSS MiB | TM peak RSS MiB |")
    print("|---|" + "---:|" * (11 + (5 if baseline else 0)))
    status = 0
    for molecule in molecules:
        try:
            r = measure(molecule, nanoshaper, tracemesh, baseline, runs, threads)
        except (RuntimeError, OSError, ValueError) as error:
            print(f"| {molecule} | failed: {str(error).splitlines()[0] if str(error) else error!r} |")
            status = 1
            continue
        ns, tm, base = r["ns"], r["tm"], r["base"]
        base_cells = (f" {base[3]} | {base[0]:.2f} | {base[0] / ns[0]:.2f} | {base[1]:.2f} | {base[2]:.0f} |"
                      if base else "")
        print(f"| {molecule} | {r['atoms']} | {r['grid_scale']:.3f} | {ns[3]} | {tm[3]} | {ns[0]:.2f} | {tm[0]:.2f} | "
              f"{tm[0] / ns[0]:.2f} |{base_cells} {ns[1]:.2f} | {tm[1]:.2f} | {ns[2]:.0f} | {tm[2]:.0f} |", flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
