#!/usr/bin/env python3
"""Sharp-kernel sweep of the trace path: where each mesh came from (first, second or third line grid, or the
lattice path), over d x t0 x density on a few molecules. The README's sweep tables come from this script.

Each job is one `tracemesh` CLI run on one thread (`--report`), so jobs run side by side (`--jobs`). With
`--baseline BIN` every job also runs with that binary, and the table shows baseline -> this binary; a job that needs
more grids than in the baseline is listed, since the level-shifted strips and the line grid retries must never make
a job worse.

Usage: bench/sharp_kernel_sweep.py [--tracemesh build/bin/tracemesh] [--baseline OLD_BIN] [--jobs 2]
           [--molecules mache,fas2,villin_1vii] [--d -20,-15,-12,-10,-8] [--t0 0.1,0.3,1,3,10]
           [--density 0.5,1,2] [--out DIR]
Writes DIR/sharp_sweep.jsonl (one object per job and binary) and DIR/sharp_sweep.md, and prints the Markdown.
Standard library only.
"""
import argparse
import concurrent.futures
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ORIGINS = ["first grid", "second grid", "third grid", "lattice path", "failed"]


def floats(text):
    return [float(x) for x in text.split(",") if x]


def run_job(binary, molecule_path, d, t0, density):
    """One CLI run; returns what the sweep records about it."""
    with tempfile.TemporaryDirectory() as tmp:
        report_path = os.path.join(tmp, "report.json")
        start = time.monotonic()
        done = subprocess.run(
            [binary, molecule_path, "--d", str(d), "--t0", str(t0), "--density", str(density), "--threads", "1",
             "-o", os.path.join(tmp, "mesh.off"), "--report", report_path],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, check=False)
        wall = time.monotonic() - start
        report = {}
        if done.returncode == 0:
            with open(report_path, encoding="utf-8") as f:
                report = json.load(f)
    trace = report.get("trace") or {}
    timings = report.get("timings") or {}
    if done.returncode != 0:
        origin = "failed"
    elif report.get("method_used") == "lattice":
        origin = "lattice path"
    else:
        origin = ORIGINS[trace.get("grid_retries", 0)]
    return {
        "exit": done.returncode, "error": done.stderr.strip()[-300:] if done.returncode else "",
        "origin": origin, "wall": wall, "failed_attempts": timings.get("failed_attempts", 0.0),
        "total": timings.get("total", 0.0), "level_shifted_strips": trace.get("level_shifted_strips"),
        "certified": (report.get("certificate") or {}).get("certified"),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tracemesh", default=os.path.join(ROOT, "build", "bin", "tracemesh"))
    parser.add_argument("--baseline", help="another tracemesh binary to compare with")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--molecules", default="mache,fas2,villin_1vii")
    parser.add_argument("--molecules-dir", default=os.environ.get("TRACEMESH_MOLECULES_DIR", os.path.join(ROOT, "tests", "data", "molecules")))
    parser.add_argument("--d", default="-20,-15,-12,-10,-8")
    parser.add_argument("--t0", default="0.1,0.3,1,3,10")
    parser.add_argument("--density", default="0.5,1,2")
    parser.add_argument("--out", default=os.path.join(ROOT, "build", "bench"))
    args = parser.parse_args()

    binaries = {"this": os.path.abspath(args.tracemesh)}
    if args.baseline:
        binaries["baseline"] = os.path.abspath(args.baseline)
    for name, path in binaries.items():
        if not os.access(path, os.X_OK):
            sys.exit(f"sharp_kernel_sweep: {name} binary {path} is not executable")
    molecules = [m for m in args.molecules.split(",") if m]
    jobs = [(m, d, t0, density) for m in molecules for d in floats(args.d) for t0 in floats(args.t0)
            for density in floats(args.density)]
    os.makedirs(args.out, exist_ok=True)
    results = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(run_job, path, os.path.join(args.molecules_dir, f"{job[0]}.pqr"), *job[1:]): (name, job)
                   for job in jobs for name, path in binaries.items()}
        for future in concurrent.futures.as_completed(futures):
            name, job = futures[future]
            results[(name, job)] = future.result()

    with open(os.path.join(args.out, "sharp_sweep.jsonl"), "w", encoding="utf-8") as f:
        for (name, (m, d, t0, density)), r in sorted(results.items()):
            f.write(json.dumps({"binary": name, "molecule": m, "d": d, "t0": t0, "density": density, **r}) + "\n")

    lines = [f"Sharp-kernel sweep: {len(jobs)} jobs, d ∈ {{{args.d}}} × t0 ∈ {{{args.t0}}} × density ∈ "
             f"{{{args.density}}}, one thread each" + (" (baseline → this binary)" if args.baseline else ""), "",
             "| molecule | " + " | ".join(ORIGINS) + " | with level-shifted strips |",
             "|---" * (len(ORIGINS) + 2) + "|"]
    worse = []
    for m in molecules:
        cells = []
        for origin in ORIGINS:
            counts = {name: sum(1 for (n, job), r in results.items() if n == name and job[0] == m
                                and r["origin"] == origin) for name in binaries}
            cells.append(f"{counts['baseline']} → {counts['this']}" if args.baseline else str(counts["this"]))
        shifted = sum(1 for (n, job), r in results.items() if n == "this" and job[0] == m
                      and (r["level_shifted_strips"] or 0) > 0)
        lines.append(f"| `{m}` | " + " | ".join(cells) + f" | {shifted} |")
        if args.baseline:
            for job in jobs:
                if job[0] != m:
                    continue
                before, after = results[("baseline", job)]["origin"], results[("this", job)]["origin"]
                if ORIGINS.index(after) > ORIGINS.index(before):
                    worse.append(f"- {m} d = {job[1]:g}, t0 = {job[2]:g}, density {job[3]:g}: {before} → {after}")
    fractions = [r["failed_attempts"] / r["total"] for (n, _), r in results.items()
                 if n == "this" and r["total"] > 0 and r["failed_attempts"] > 0]
    lines.append("")
    if fractions:
        lines.append(f"Jobs with a failed attempt spend a median {100 * statistics.median(fractions):.0f}% of their "
                     f"time on failed attempts ({len(fractions)} jobs).")
    if args.baseline:
        lines.append("Jobs that need more grids than the baseline: " + ("none." if not worse else ""))
        lines.extend(worse)
    failures = [f"- {job[0]} d = {job[1]:g}, t0 = {job[2]:g}, density {job[3]:g} ({n}): {r['error']}"
                for (n, job), r in sorted(results.items()) if r["origin"] == "failed"]
    if failures:
        lines.append("Failed jobs:")
        lines.extend(failures)
    text = "\n".join(lines) + "\n"
    with open(os.path.join(args.out, "sharp_sweep.md"), "w", encoding="utf-8") as f:
        f.write(text)
    print(text, end="")
    return 1 if worse else 0


if __name__ == "__main__":
    sys.exit(main())
