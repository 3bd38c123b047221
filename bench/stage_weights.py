#!/usr/bin/env python3
"""Stage weights for progress and ETA, from the molecule ladder's per-stage seconds.

Reads the JSON lines that bench/run_ladder.sh writes (ladder_bench --json: "seconds" per stage, "read_seconds"),
sums each stage's seconds over every measured row of a path (lattice refined, trace raw, trace refined), and prints
a Markdown table of the seconds and shares, the spread of each share over the rows that took at least MIN_SECONDS,
and the C++ block that core/stage_weights.cpp holds between WEIGHTS-BEGIN and WEIGHTS-END.

Summing seconds (rather than averaging shares) weights the big molecules most: they are the jobs whose progress
and ETA anyone watches.

Usage: python3 bench/stage_weights.py [LADDER_JSONL] [MIN_SECONDS]
  e.g. RUNS=1 MAX_ATOMS=17214 bench/run_ladder.sh && python3 bench/stage_weights.py build/bench/ladder.jsonl
"""
import json
import sys

# mesh_stage order (core/progress.hpp), without done.
STAGES = ["reading", "culling", "sampling", "roots", "tracing", "triangulating", "refining", "certifying", "encoding"]
PATHS = [("lattice refined", "lattice_refined_weights"), ("trace raw", "trace_raw_weights"),
         ("trace refined", "trace_refined_weights")]
# The service's last stage (storing the mesh and report in the job store; the CLI's writing the file) is not
# timed by ladder_bench: it gets this share of the measured total.
ENCODING_SHARE_OF_MEASURED = 0.02


def stage_seconds(row):
    seconds = dict(row.get("seconds", {}))
    seconds.pop("total", None)
    seconds["reading"] = row.get("read_seconds", 0.0)
    return seconds


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "build/bench/ladder.jsonl"
    min_seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 0.1
    with open(path, encoding="utf-8") as f:
        rows = [json.loads(line) for line in f if line.strip()]
    rows = [r for r in rows if r.get("status") == "ok"]
    if not rows:
        sys.exit(f"stage_weights: no measured rows in {path}")

    print(f"Stage seconds summed over the ladder rows in {path} ({len(rows)} rows), share of each path's total;")
    print(f"range: the share's min–max over rows of at least {min_seconds} s.\n")
    print("| path | rows | " + " | ".join(STAGES) + " |")
    print("|---|---|" + "---|" * len(STAGES))
    blocks = []
    for label, constant in PATHS:
        mine = [r for r in rows if r.get("path") == label]
        if not mine:
            continue
        totals = {s: 0.0 for s in STAGES}
        for r in mine:
            for s, v in stage_seconds(r).items():
                totals[s] = totals.get(s, 0.0) + v
        measured = sum(totals.values())
        totals["encoding"] = ENCODING_SHARE_OF_MEASURED * measured
        grand = sum(totals.values())
        spreads = {}
        for r in mine:
            secs = stage_seconds(r)
            row_total = sum(secs.values())
            if row_total < min_seconds:
                continue
            for s in STAGES:
                share = secs.get(s, 0.0) / row_total
                lo, hi = spreads.get(s, (share, share))
                spreads[s] = (min(lo, share), max(hi, share))
        cells = []
        for s in STAGES:
            share = totals[s] / grand
            lo, hi = spreads.get(s, (None, None))
            spread = f" ({lo:.2f}–{hi:.2f})" if lo is not None and s != "encoding" else ""
            cells.append(f"{totals[s]:.2f} s, {share:.3f}{spread}")
        print(f"| {label} | {len(mine)} | " + " | ".join(cells) + " |")
        weights = ", ".join(f"{totals[s] / grand:.4f}" for s in STAGES)
        blocks.append(f"constexpr stage_shares {constant} = {{\n    {weights}}};")

    print("\nFor core/stage_weights.cpp (order: " + ", ".join(STAGES) + "):\n")
    for b in blocks:
        print(b)


if __name__ == "__main__":
    main()
