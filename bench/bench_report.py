#!/usr/bin/env python3
"""Turns ladder_bench's JSON rows into the benchmark summaries and the paper-reproduction report.

Every row is one JSON object per line, written by bench/ladder_bench.cpp (or, for a process that crashed or timed
out, by bench/bench_lib.sh): molecule, atoms, density, path ("lattice refined", "trace raw", "trace refined"),
threads, runs, status ("ok" | "failed"), error, read_seconds, peak_rss_mb and, when ok, seconds (median per stage
and "total"), cpu_seconds, edge_ratio_bins (100 bins of shortest/longest edge per triangle) and report (the job
report of the last run, as the service returns it: proto/report_json.hpp).

Subcommands:
  ladder-summary ROWS.jsonl [--full-ladder yes|no]
      Prints (Markdown) the trace/lattice total-time ratios at densities 1 and 2 and the issue's default rule:
      trace becomes the default if trace refined is certified on every ladder molecule and its total time is
      within 1.25x of the lattice path's at densities 1 and 2. Needs only the standard library.
  paper DATA_DIR OUT_DIR
      Reads DATA_DIR/rows.jsonl and DATA_DIR/meta.json (bench/run_paper.sh writes both) and writes
      OUT_DIR/report.md with the figures fig5_edge_ratio.png, fig6_convergence.png and fig3_linear_cost.png.
      A "note" in meta.json (e.g. on rows measured apart and appended to rows.jsonl) joins the report's first
      paragraph. Needs matplotlib (Debian: python3-matplotlib).
"""

import argparse
import json
import math
import sys
from pathlib import Path

PATHS = ("trace raw", "trace refined", "lattice refined")
COLOURS = {"trace raw": "tab:orange", "trace refined": "tab:blue", "lattice refined": "0.35"}
LADDER = (  # name, atoms (docs/benchmarks.md lists them); bench/bench_lib.sh holds the same list
    ("gly", 7), ("adp", 39), ("villin_1vii", 596), ("fas2", 906), ("mache", 8279), ("achbp", 16090),
    ("3j6r_asu", 17214), ("1ihm_asu", 22281), ("2buk_12asu", 34284), ("1k4r_5asu", 90180),
    ("2buk_capsid", 171420), ("1rb8_capsid", 589680), ("1k4r_capsid", 1082160),
)
DEFAULT_RULE_RATIO = 1.25

# Chen & Lu 2011, Table 2 (method.md §6): name -> (paper entry, atoms, {density: (CPU s, MB or None)}).
PAPER_TABLE2 = {
    "fas2": ("FAS2", 906, {1: (1.2, 2), 2: (1.8, 4)}),
    "mache": ("AChE monomer", 8280, {1: (12, 11), 2: (19, 19)}),
    "1k4r_capsid": ("1K4R", 1082160, {1: (1260, 630), 2: (2080, 890)}),
}
# The paper's Table 2 times for the linear-cost figure (atoms, s at 1 v/Å², s at 2 v/Å²), one 3.3 GHz core (2011).
PAPER_TIMES = ((906, 1.2, 1.8), (8280, 12, 19), (36638, 40, 62), (88431, 92, 151), (165337, 180, 283),
               (203135, 226, 359), (510727, 577, 910), (1082160, 1260, 2080))
TABLE2_MOLECULES = ("fas2", "mache", "1k4r_5asu", "2buk_capsid", "1k4r_capsid")
FIG5 = (("fas2", 2), ("fas2", 10), ("mache", 2), ("mache", 10))
FIG6_MOLECULES = ("gly", "adp", "villin_1vii")
FIG6_DENSITIES = (0.5, 1, 2, 4, 6, 8, 10)
REFERENCE_MOLECULES = ("fas2", "mache", "2buk_12asu")  # compared with the lattice at 8 v/Å²
REFERENCE_DENSITY = 8


# ---------------------------------------------------------------------------------------------------- rows

def molecule_name(file_name):
    """gly.pqr / 1k4r_capsid.pqr.gz -> gly / 1k4r_capsid."""
    name = Path(file_name).name
    for suffix in (".gz", ".pqr"):
        name = name[: -len(suffix)] if name.endswith(suffix) else name
    return name


def load_rows(path):
    """{(molecule, density, path, threads): row}; a later line replaces an earlier one (resumed runs)."""
    rows = {}
    for number, line in enumerate(Path(path).read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except json.JSONDecodeError as error:
            print(f"bench_report: {path}:{number}: skipped ({error})", file=sys.stderr)
            continue
        row["name"] = molecule_name(row["molecule"])
        rows[(row["name"], float(row["density"]), row["path"], int(row["threads"]))] = row
    return rows


def ok(row):
    return row is not None and row.get("status") == "ok"


def certified(row):
    return ok(row) and row["report"]["certificate"]["certified"]


def total(row):
    return row["seconds"]["total"]


def quality(row, field):
    return row["report"]["quality"][field]


def status_text(row):
    """Why a row has no value, in a table cell; the paper report lists every failure with its reason at the end."""
    return "not measured" if row is None else "failed"


# ---------------------------------------------------------------------------------------------------- formatting

def seconds(value):
    if value >= 100:
        return f"{value:,.0f}"
    return f"{value:.2f}" if value >= 1 else f"{value:.3f}"


def megabytes(value):
    return f"{value:,.0f}"


def percent(fraction, digits=2):
    return f"{100 * fraction:.{digits}f}%"


def table(header, rows):
    """A Markdown table from a header list and rows of cells."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------------- ladder summary

def ladder_summary(rows, threads=None, full_ladder=True):
    """Markdown: trace/lattice total time per ladder molecule at densities 1 and 2, and the default rule."""
    if threads is None:  # the ladder run has one thread count; take the largest present
        threads = max((key[3] for key in rows), default=0)
    names = [name for name, _ in LADDER if any(key[0] == name and key[3] == threads for key in rows)]
    densities = [d for d in (1.0, 2.0) if any(key[1] == d and key[3] == threads for key in rows)]
    body, worst, sums, failures = [], {}, {}, []
    for name in names:
        cells = [name, f"{dict(LADDER)[name]:,}"]
        for density in densities:
            lattice = rows.get((name, density, "lattice refined", threads))
            for path in ("trace raw", "trace refined"):
                trace = rows.get((name, density, path, threads))
                if path == "trace refined" and not certified(trace):
                    why = "not certified" if ok(trace) else status_text(trace)
                    failures.append(f"{name} at {density:g} v/Å² ({why})")
                if not (ok(trace) and ok(lattice)):
                    cells.append("—")
                    continue
                ratio = total(trace) / total(lattice)
                cells.append(f"{ratio:.2f}")
                if ratio > worst.get((path, density), (0, ""))[0]:
                    worst[(path, density)] = (ratio, name)
                summed = sums.setdefault((path, density), [0.0, 0.0])
                summed[0] += total(trace)
                summed[1] += total(lattice)
            cells.append(" / ".join("yes" if certified(rows.get((name, density, p, threads))) else "no"
                                    for p in PATHS))
        body.append(cells)
    header = ["molecule", "atoms"]
    for density in densities:
        header += [f"{density:g} v/Å² {column}" for column in ("raw", "refined", "certified raw / refined / lattice")]
    out = [f"### Trace / lattice total time ({threads} threads; trace ÷ lattice refined at the same density, "
           "< 1: trace faster; — where a row failed)", "", table(header, body), ""]
    for path in ("trace raw", "trace refined"):
        parts = []
        for density in densities:
            if (path, density) in worst:
                ratio, name = worst[(path, density)]
                summed = sums[(path, density)]
                parts.append(f"at {density:g} v/Å² worst {ratio:.2f} ({name}), all molecules together "
                             f"{summed[0] / summed[1]:.2f}")
            else:
                parts.append(f"at {density:g} v/Å² no pair measured")
        out.append(f"- {path}: " + "; ".join(parts))
    # The rule compares the trace path's total time with the lattice path's at each density: summed over
    # the ladder. Single rows are listed too; the smallest take milliseconds, where fixed costs and the timer move a
    # ratio by ±0.5 between runs (gly at 1 v/Å²: 1.46 in a ladder run, 0.74–1.05 re-run alone).
    together = {d: sums[("trace refined", d)][0] / sums[("trace refined", d)][1]
                for d in densities if ("trace refined", d) in sums}
    ratios_ok = all(d in together and together[d] <= DEFAULT_RULE_RATIO for d in densities)
    missing = [f"{d:g} v/Å²" for d in (1.0, 2.0) if d not in densities]
    met = not failures and ratios_ok and names and not missing
    verdict = "met" if met else "not met"
    if met and not full_ladder:
        verdict = "met on the molecules measured (not the whole ladder: the rule needs all of it)"
    if not met and not failures and ratios_ok and missing:
        verdict = f"not measured at {', '.join(missing)}"
    out += ["", f"**Default rule** (the issue's: trace refined certified on every ladder molecule, and its total "
                f"time over the ladder within {DEFAULT_RULE_RATIO}× of the lattice path's at 1 and at 2 v/Å²): "
                f"**{verdict}**."]
    if failures:
        out.append("Trace refined not certified: " + "; ".join(failures) + ".")
    out.append("Trace refined ÷ lattice over the ladder: " +
               ("; ".join(f"{together[d]:.2f} at {d:g} v/Å²" for d in densities if d in together) or "none measured")
               + ".")
    over = []
    for name in names:
        for density in densities:
            trace = rows.get((name, density, "trace refined", threads))
            lattice = rows.get((name, density, "lattice refined", threads))
            if ok(trace) and ok(lattice) and total(trace) > DEFAULT_RULE_RATIO * total(lattice):
                over.append(f"{name} at {density:g} v/Å² {total(trace) / total(lattice):.2f} "
                            f"({seconds_text(total(trace))} against {seconds_text(total(lattice))})")
    out.append(f"Single molecules over {DEFAULT_RULE_RATIO}×: " + ("; ".join(over) if over else "none") + ".")
    return "\n".join(out)


def seconds_text(seconds):
    """A duration for prose: milliseconds under one second."""
    return f"{1000 * seconds:.1f} ms" if seconds < 1 else f"{seconds:.1f} s"


# ---------------------------------------------------------------------------------------------------- paper report

def table2_section(rows):
    out = ["## Table 2 side by side", "",
           "The paper: CPU seconds and MB on one 3.3 GHz Xeon core (2011). Ours: wall seconds of `mesh_molecule` "
           "(reading excluded; CPU seconds given for the one-thread run), peak RSS of the first run (the molecule "
           "included), on 1 and 2 threads; vertices and achieved density of the mesh (the same on any thread count).",
           ""]
    body = []
    for name in TABLE2_MOLECULES:
        entry = PAPER_TABLE2.get(name)
        atoms = dict(LADDER)[name]
        for density in (1, 2):
            paper = entry[2][density] if entry else None
            for index, path in enumerate(PATHS):
                one = rows.get((name, float(density), path, 1))
                two = rows.get((name, float(density), path, 2))
                first = index == 0
                cells = [f"{name}" if first else "", f"{atoms:,}" if first else "", density if first else "",
                         (f"{paper[0]:,g}" if paper else "—") if first else "",
                         (f"{paper[1]:,g}" if paper else "—") if first else "", path]
                for row in (one, two):
                    if ok(row):
                        cells += [seconds(total(row)), megabytes(row["peak_rss_mb"])]
                    else:
                        cells += [status_text(row), ""]
                cells.append(seconds(one["cpu_seconds"]) if ok(one) else "")
                shown = two if ok(two) else one
                if ok(shown):
                    cells += [f"{shown['report']['vertices']:,}", f"{shown['report']['achieved_density']:.2f}",
                              "yes" if certified(shown) else "NO"]
                else:
                    cells += ["", "", ""]
                body.append(cells)
    out.append(table(["molecule", "atoms", "v/Å²", "paper CPU s", "paper MB", "path", "1 thread s", "1 thread MB",
                      "2 threads s", "2 threads MB", "1 thread CPU s", "vertices", "achieved v/Å²", "certified"],
                     body))
    out += ["", "No paper row exists for `1k4r_5asu` or `2buk_capsid` (—). Of similar size in the paper: the 30S "
                "ribosome (88,431 atoms, 92 / 151 s) and the 70S ribosome (165,337 atoms, 180 / 283 s)."]
    return "\n".join(out)


def fig5_section(rows, out_dir, plt):
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    body = []
    for ax, (name, density) in zip(axes.flat, FIG5):
        for path in PATHS:
            row = rows.get((name, float(density), path, 2))
            if not ok(row):
                body.append([name, density, path, status_text(row), "", "", ""])
                continue
            bins = row["edge_ratio_bins"]
            count = sum(bins) or 1
            edges = [i / len(bins) for i in range(len(bins) + 1)]
            ax.stairs([b / count for b in bins], edges, label=path, color=COLOURS[path], linewidth=1.4)
            peak = (bins.index(max(bins)) + 0.5) / len(bins)
            body.append([name, density, path, f"{quality(row, 'edge_ratio_mean'):.3f}",
                         percent(quality(row, "fraction_below_0_2")), f"{peak:.3f}",
                         f"{row['report']['triangles']:,}"])
        ax.axvline(0.75, color="tab:red", linestyle="--", linewidth=1, label="paper: clusters around 0.75")
        ax.set_title(f"{name}, {density} v/Å²")
        ax.set_ylabel("fraction of triangles per 0.01 bin")
    for ax in axes[-1]:
        ax.set_xlabel("edge ratio (shortest / longest edge)")
    legend = {}  # one legend for the figure, whichever panels have which paths
    for ax in axes.flat:
        legend.update(zip(*reversed(ax.get_legend_handles_labels())))
    fig.legend(legend.values(), legend.keys(), loc="lower center", ncol=len(legend), fontsize=9)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    fig.savefig(out_dir / "fig5_edge_ratio.png", dpi=120)
    plt.close(fig)
    return "\n".join(["## Figure 5: triangle edge ratio", "",
                      "![edge ratio histograms](fig5_edge_ratio.png)", "",
                      "Histograms of 100 bins computed by ladder_bench from every triangle of the mesh (2 threads).",
                      "",
                      table(["molecule", "v/Å²", "path", "mean", "< 0.2", "mode", "triangles"], body)])


def fig6_section(rows, out_dir, plt):
    fig, axes = plt.subplots(2, len(FIG6_MOLECULES), figsize=(12, 6.5))
    body = []
    for column, name in enumerate(FIG6_MOLECULES):
        for path in PATHS:
            points = [(d, row) for d in FIG6_DENSITIES if ok(row := rows.get((name, float(d), path, 2)))]
            for line, field in enumerate(("area", "volume")):
                axes[line][column].plot([d for d, _ in points], [row["report"][field] for _, row in points],
                                        marker="o", markersize=3, label=path, color=COLOURS[path])
        axes[0][column].set_title(name)
        axes[0][column].set_ylabel("area (Å²)")
        axes[1][column].set_ylabel("volume (Å³)")
        axes[1][column].set_xlabel("density (vertices/Å²)")
        finest = rows.get((name, float(FIG6_DENSITIES[-1]), "lattice refined", 2))
        for density in FIG6_DENSITIES:
            cells = [name, density]
            for field in ("area", "volume"):
                values = []
                for path in PATHS:
                    row = rows.get((name, float(density), path, 2))
                    if not ok(row):
                        values.append("failed" if row else "—")
                        continue
                    value = row["report"][field]
                    deviation = f" ({100 * (value / finest['report'][field] - 1):+.2f}%)" if ok(finest) else ""
                    values.append(f"{value:,.1f}{deviation}")
                cells.append(" / ".join(values))
            body.append(cells)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / "fig6_convergence.png", dpi=120)
    plt.close(fig)
    return "\n".join([
        "## Figure 6: area and volume against density", "",
        "![area and volume against density](fig6_convergence.png)", "",
        f"2 threads. In parentheses: the deviation from the lattice refined mesh at {FIG6_DENSITIES[-1]} v/Å².", "",
        table(["molecule", "v/Å²", "area Å²: " + " / ".join(PATHS), "volume Å³: " + " / ".join(PATHS)], body)])


def loglog_slope(points):
    """Least-squares slope of log(time) against log(atoms); None with fewer than 2 points."""
    if len(points) < 2:
        return None
    xs = [math.log(x) for x, _ in points]
    ys = [math.log(y) for _, y in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx else None


def linear_cost_section(rows, out_dir, plt):
    fig, axes = plt.subplots(1, 2, figsize=(12, 5), sharey=True)
    body = []
    for ax, density in zip(axes, (1, 2)):
        for path in PATHS:
            points = [(atoms, total(row)) for name, atoms in LADDER
                      if ok(row := rows.get((name, float(density), path, 2)))]
            if points:
                ax.loglog(*zip(*points), marker="o", markersize=4, label=path, color=COLOURS[path])
            big = [(a, t) for a, t in points if a >= 10_000]
            slope = loglog_slope(big)
            per_atom = [1e6 * t / a for a, t in big]
            body.append([density, path, len(points), f"{slope:.2f}" if slope is not None else "—",
                         f"{min(per_atom):.1f}–{max(per_atom):.1f}" if per_atom else "—"])
        paper = [(atoms, times[density - 1]) for atoms, *times in PAPER_TIMES]
        ax.loglog(*zip(*paper), linestyle=":", marker="s", markersize=4, color="0.6",
                  label="paper Table 2 (1 core, 2011)")
        slope = loglog_slope([p for p in paper if p[0] >= 10_000])
        body.append([density, "paper Table 2", len(paper), f"{slope:.2f}", "—"])
        ax.set_title(f"{density} v/Å², 2 threads")
        ax.set_xlabel("atoms")
        ax.grid(True, which="both", linewidth=0.3)
    axes[0].set_ylabel("total seconds")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / "fig3_linear_cost.png", dpi=120)
    plt.close(fig)
    return "\n".join([
        "## Linear cost (paper Fig. 3)", "",
        "![time against atoms](fig3_linear_cost.png)", "",
        "Slope of log time against log atoms over the ladder molecules from 10⁴ atoms up (1 = linear); different "
        "molecules carry different surface per atom, so the same molecule grown (`2buk_12asu` → `2buk_capsid`, "
        "`1k4r_5asu` → `1k4r_capsid`) is the cleaner test.", "",
        table(["v/Å²", "path", "molecules", "slope (≥ 10⁴ atoms)", "µs per atom (≥ 10⁴ atoms)"], body)])


def targets_section(rows, ladder_names, full_ladder):
    """The issue's targets, each with the measured value and met / not met."""
    lines = []

    def add(target, measured, met):
        status = {True: "met", False: "not met", None: "not measured"}[met]
        lines.append([target, measured, status])

    for density, limit_s, limit_mb in ((1, 60, 2048), (2, 120, None)):
        row = rows.get(("1k4r_capsid", float(density), "trace refined", 2))
        target = f"trace refined `1k4r_capsid` at {density} v/Å², 2 threads: certified, < {limit_s} s" + (
            ", < 2 GB (2,048 MB)" if limit_mb else "")
        if ok(row):
            met = certified(row) and total(row) < limit_s and (limit_mb is None or row["peak_rss_mb"] < limit_mb)
            add(target, f"{seconds(total(row))} s, {megabytes(row['peak_rss_mb'])} MB, "
                        f"{'certified' if certified(row) else 'not certified'}", met)
        else:
            add(target, status_text(row), None if row is None else False)

    def over_ladder(path):
        found = [rows.get((n, float(d), path, 2)) for n in ladder_names for d in (1, 2)]
        return [r for r in found if r is not None], len(found) - sum(r is not None for r in found)

    subset = "" if full_ladder else " (molecules measured; not the whole ladder)"
    raw, _ = over_ladder("trace raw")
    good = [r for r in raw if certified(r)]
    bad = [f"{r['name']} at {r['density']:g}" for r in raw if not certified(r)]
    add("trace raw: certified on every ladder molecule (1 and 2 v/Å²)" + subset,
        f"{len(good)} of {len(raw)} rows certified" + (f"; not: {', '.join(bad)}" if bad else ""),
        (len(good) == len(raw)) if raw else None)

    for path, mean_min, below_max, shortest in (("trace raw", 0.70, 0.01, None), ("trace refined", 0.80, 0.005, 0.1)):
        measured_rows = [r for r in over_ladder(path)[0] if ok(r)]
        if not measured_rows:
            add(f"{path}: edge-ratio mean ≥ {mean_min}", "no row measured", None)
            continue
        worst_mean = min(measured_rows, key=lambda r: quality(r, "edge_ratio_mean"))
        worst_below = max(measured_rows, key=lambda r: quality(r, "fraction_below_0_2"))
        add(f"{path}: edge-ratio mean ≥ {mean_min:.2f}{subset}",
            f"lowest {quality(worst_mean, 'edge_ratio_mean'):.3f} ({worst_mean['name']} at "
            f"{worst_mean['density']:g})", quality(worst_mean, "edge_ratio_mean") >= mean_min)
        add(f"{path}: < {percent(below_max, 1)} of triangles below 0.2{subset}",
            f"highest {percent(quality(worst_below, 'fraction_below_0_2'))} ({worst_below['name']} at "
            f"{worst_below['density']:g})", quality(worst_below, "fraction_below_0_2") < below_max)
        if shortest:
            ratio = lambda r: quality(r, "shortest_edge") / quality(r, "median_edge")  # noqa: E731
            worst_short = min(measured_rows, key=ratio)
            add(f"{path}: shortest edge ≥ {shortest} × median edge{subset}",
                f"lowest {ratio(worst_short):.3f} × median ({worst_short['name']} at {worst_short['density']:g})",
                ratio(worst_short) >= shortest)

    for name in REFERENCE_MOLECULES:
        reference = rows.get((name, float(REFERENCE_DENSITY), "lattice refined", 2))
        for path in ("trace refined", "trace raw"):
            row = rows.get((name, 2.0, path, 2))
            reference_text = f"lattice at {REFERENCE_DENSITY} v/Å²"
            geometry = f"{path} `{name}` at 2 v/Å²: area and volume within 1% of {reference_text}"
            topology = f"{path} `{name}` at 2 v/Å²: components and genus equal to {reference_text}"
            if not (ok(row) and ok(reference)):
                why = status_text(row) if not ok(row) else f"reference {status_text(reference)}"
                met = None if (row is None or reference is None) else False
                add(geometry, why, met)
                add(topology, why, met)
                continue
            r, ref = row["report"], reference["report"]
            da, dv = r["area"] / ref["area"] - 1, r["volume"] / ref["volume"] - 1
            add(geometry, f"area {100 * da:+.2f}%, volume {100 * dv:+.2f}%", abs(da) < 0.01 and abs(dv) < 0.01)
            comps, ref_comps = len(r["components"]), len(ref["components"])
            add(topology, f"{comps} components, genus {r['genus']} (reference {ref_comps}, {ref['genus']})",
                comps == ref_comps and r["genus"] == ref["genus"])

    row = rows.get(("fas2", 1.0, "trace refined", 2))
    if ok(row):
        end_to_end = row["read_seconds"] + total(row)
        add("trace refined `fas2` end to end (read + mesh, 1 v/Å², 2 threads) < 50 ms",
            f"{1000 * end_to_end:.0f} ms", end_to_end < 0.050)
    else:
        add("trace refined `fas2` end to end < 50 ms", status_text(row), None if row is None else False)
    return "\n".join(["## Targets (from the issue)", "", table(["target", "measured", ""], lines)])


def failed_rows_section(rows):
    failed = [row for row in rows.values() if not ok(row)]
    if not failed:
        return "## Failed rows\n\nNone."
    body = [[row["name"], f"{row['density']:g}", row["path"], row["threads"], row.get("error", "")]
            for row in sorted(failed, key=lambda r: (r.get("atoms", 0), r["density"], r["path"], r["threads"]))]
    return "\n".join(["## Failed rows", "", table(["molecule", "v/Å²", "path", "threads", "why"], body)])


def paper_report(data_dir, out_dir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = load_rows(data_dir / "rows.jsonl")
    meta = json.loads((data_dir / "meta.json").read_text(encoding="utf-8"))
    max_atoms = meta.get("paper_max_atoms") or None
    ladder_names = [name for name, atoms in LADDER if max_atoms is None or atoms <= int(max_atoms)]
    full_ladder = len(ladder_names) == len(LADDER)
    out_dir.mkdir(parents=True, exist_ok=True)
    machine = (f"{meta['cores']} cores ({meta['cpu']}), {meta['memory_gib']} GiB; {meta['date']}; commit "
               f"{meta['commit']}")
    parts = [
        "# TMSmesh (Chen & Lu, JCTC 2011) reproduced with tracemesh", "",
        f"Generated by `make bench-paper` (bench/run_paper.sh, bench/bench_report.py). Machine: {machine}. "
        f"Every timed row is the median of {meta['runs']} run{'s' if meta['runs'] != 1 else ''} in its own process "
        f"(peak RSS: the first run); the "
        f"lattice references at {REFERENCE_DENSITY} v/Å² are one run each (only their geometry is used). "
        f"Rows not marked otherwise use 2 threads. "
        + (f"Molecules over {int(max_atoms):,} atoms were skipped (PAPER_MAX_ATOMS)." if max_atoms else
           "All molecules were measured.")
        + (f" {meta['note']}" if meta.get("note") else "")
        + f" Raw rows: `{data_dir.name}/rows.jsonl` (JSON) and `{data_dir.name}/rows.md` (Markdown). A cell that "
        "says failed is a row whose run reported an error or whose process died; \"Failed rows\" at the end gives "
        "each reason.",
        "",
        targets_section(rows, ladder_names, full_ladder), "",
        table2_section(rows), "",
        fig5_section(rows, out_dir, plt), "",
        fig6_section(rows, out_dir, plt), "",
        linear_cost_section(rows, out_dir, plt), "",
        "## The ladder: trace against lattice", "",
        ladder_summary(rows, threads=2, full_ladder=full_ladder), "",
        failed_rows_section(rows), "",
    ]
    (out_dir / "report.md").write_text("\n".join(parts), encoding="utf-8")
    print(f"bench_report: wrote {out_dir / 'report.md'} and its figures", file=sys.stderr)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(dest="command", required=True)
    summary = commands.add_parser("ladder-summary")
    summary.add_argument("rows", type=Path)
    summary.add_argument("--full-ladder", choices=("yes", "no"), default="yes")
    paper = commands.add_parser("paper")
    paper.add_argument("data_dir", type=Path)
    paper.add_argument("out_dir", type=Path)
    args = parser.parse_args()
    if args.command == "ladder-summary":
        print(ladder_summary(load_rows(args.rows), full_ladder=args.full_ladder == "yes"))
    else:
        paper_report(args.data_dir, args.out_dir)


if __name__ == "__main__":
    main()
