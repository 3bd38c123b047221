#!/usr/bin/env python3
"""Soak benchmark of tracemeshd (make bench-soak; not in CI): the load benchmark's request mix (bench/load_bench.py:
the same kinds, shares, clients and checks, imported from it) at a fixed concurrency for a long time against one
real server, watching whether the server process leaks.

Every SAMPLE_SECONDS (10 s) the server's resident memory (VmRSS), open file descriptors and threads are read from
/proc/<pid>. The report is a Markdown table per WINDOW_SECONDS (5 min): the median RSS, fds and threads of the
window's samples, the requests answered in it and its 5xx. The verdict passes when, after the first window (warm-up:
caches and pools fill), each window's median RSS, fds and threads stays within ±10% of the median of those
windows, no response is a 5xx, every request got a complete response and none got a status its kind must never get
(load_bench.allowed). Exit status 1 otherwise.

Usage: soak_bench.py --daemon build/bin/tracemeshd [--molecules DIR] [--duration 1800] [--concurrency 16]
                     [--clients 16] [--seed N] [--slow-seconds 1.0]
                     [--url http://127.0.0.1:PORT --pid PID (an already running server on this machine)]
"""
import argparse
import asyncio
import os
import random
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import load_bench  # noqa: E402  (the request mix, the exchange and the allowed statuses)

SAMPLE_SECONDS = 10
WINDOW_SECONDS = 300
TOLERANCE = 0.10  # ±10% of the median after the warm-up window


def process_sample(pid: int) -> dict:
    """RSS (MiB), open fds and threads of process `pid`, from /proc."""
    rss_kib = threads = 0
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                rss_kib = int(line.split()[1])
            elif line.startswith("Threads:"):
                threads = int(line.split()[1])
    return {"rss": rss_kib / 1024.0, "fds": len(os.listdir(f"/proc/{pid}/fd")), "threads": threads}


async def soak(args, host: str, port: int, pid: int):
    """Runs the mix for args.duration seconds: (samples [(t, sample)], results [(t, kind, status, seconds)])."""
    plan = load_bench.Plan(args.molecules, 0, args.seed, f"{host}:{port}")
    for head, body in plan.warm_up():
        status, _ = await load_bench.exchange(host, port, head, body, 1, 0)
        if status != 200:
            sys.exit(f"soak_bench: warm-up request answered {status}")
    kinds = [k for k, share in load_bench.KIND_SHARES for _ in range(share)]
    clients = [f"127.0.0.{2 + n}" for n in range(args.clients)] if host.startswith("127.") else [None]
    rng = random.Random(args.seed)
    start = time.monotonic()
    end = start + args.duration
    samples, results = [], []

    async def sampler():
        while time.monotonic() < end:
            samples.append((time.monotonic() - start, process_sample(pid)))
            await asyncio.sleep(SAMPLE_SECONDS)

    async def client_loop(number: int):
        sent = 0
        while time.monotonic() < end:
            kind, head, body = plan.make(rng.choice(kinds), rng)
            pieces = 8 if kind == "slow_body" else 1
            client = clients[(number + sent) % len(clients)]
            sent += 1
            status, seconds = await load_bench.exchange(host, port, head, body, pieces, args.slow_seconds, client)
            results.append((time.monotonic() - start, kind, status, seconds))

    await asyncio.gather(sampler(), *(client_loop(n) for n in range(args.concurrency)))
    return samples, results


def report(samples, results, args) -> int:
    windows = max(1, -(-int(args.duration) // WINDOW_SECONDS))
    print(f"{len(results)} requests over {args.duration:.0f} s, {args.concurrency} concurrent from {args.clients} "
          f"clients, seed {args.seed}; {len(samples)} samples every {SAMPLE_SECONDS} s\n")
    print("| window | median RSS MiB | median fds | median threads | requests | 5xx | no reply |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for w in range(windows):
        low, high = w * WINDOW_SECONDS, (w + 1) * WINDOW_SECONDS
        in_window = [s for t, s in samples if low <= t < high]
        answered = [r for r in results if low <= r[0] < high]
        median = lambda key: statistics.median(s[key] for s in in_window) if in_window else float("nan")
        print(f"| {low // 60}–{min(high, int(args.duration)) // 60} min | {median('rss'):.1f} | {median('fds'):.0f} | "
              f"{median('threads'):.0f} | {len(answered)} | {sum(1 for r in answered if r[2] >= 500)} | "
              f"{sum(1 for r in answered if r[2] == 0)} |")

    failures = []
    # A sample catches however many requests are in flight at that instant (each holds a socket and buffers), so
    # single samples swing with the load; a leak moves the window medians, which is what the verdict judges.
    medians = {key: [] for key in ("rss", "fds", "threads")}
    for w in range(1 if windows > 1 else 0, windows):
        in_window = [s for t, s in samples if w * WINDOW_SECONDS <= t < (w + 1) * WINDOW_SECONDS]
        for key in medians:
            if in_window:
                medians[key].append(statistics.median(s[key] for s in in_window))
    for key, unit in (("rss", "MiB"), ("fds", "fds"), ("threads", "threads")):
        values = medians[key]
        median = statistics.median(values)
        low, high = min(values), max(values)
        within = median * (1 - TOLERANCE) <= low and high <= median * (1 + TOLERANCE)
        print(f"\n{key}: window medians {low:.1f}–{high:.1f} {unit} around {median:.1f} after the first window: "
              f"{'within' if within else 'OUTSIDE'} ±{TOLERANCE:.0%}", end="")
        if not within:
            failures.append(f"{key} left ±{TOLERANCE:.0%} of its median ({low:.1f}–{high:.1f} around {median:.1f})")
    print()
    server_errors = sum(1 for r in results if r[2] >= 500)
    unanswered = sum(1 for r in results if r[2] == 0)
    wrong = sorted({f"{r[1]}: {r[2]}" for r in results if r[2] != 0 and not load_bench.allowed(r[1], r[2])})
    if server_errors:
        failures.append(f"{server_errors} responses were 5xx")
    if unanswered:
        failures.append(f"{unanswered} requests got no complete response")
    if wrong:
        failures.append(f"statuses a kind must never get: {wrong}")
    statuses = {}
    for r in results:
        statuses[r[2]] = statuses.get(r[2], 0) + 1
    print(f"statuses: {dict(sorted(statuses.items()))}")
    print("verdict: " + ("PASS" if not failures else "FAIL: " + "; ".join(failures)))
    return 1 if failures else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--daemon", default="build/bin/tracemeshd")
    parser.add_argument("--molecules", default=os.environ.get("TRACEMESH_MOLECULES_DIR",
                        os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "molecules")))
    parser.add_argument("--duration", type=float, default=1800, help="seconds of load (default 1800)")
    parser.add_argument("--concurrency", type=int, default=16)
    parser.add_argument("--clients", type=int, default=16, help="loopback client addresses (1 to 250)")
    parser.add_argument("--seed", type=int, default=12)
    parser.add_argument("--slow-seconds", type=float, default=1.0)
    parser.add_argument("--url", help="an already running server on this machine, http://host:port (with --pid)")
    parser.add_argument("--pid", type=int, help="with --url: the server's process id, sampled through /proc")
    args = parser.parse_args()
    if not 1 <= args.clients <= 250:
        parser.error("--clients must be within 1 to 250")
    if args.duration < SAMPLE_SECONDS:
        parser.error(f"--duration must be at least {SAMPLE_SECONDS} s")
    if bool(args.url) != bool(args.pid):
        parser.error("--url and --pid go together")
    with load_bench.target_server(args.url, args.daemon, "tracemesh-soak-") as (host, port, process):
        pid = process.pid if process is not None else args.pid
        samples, results = asyncio.run(soak(args, host, port, pid))
        return report(samples, results, args)

if __name__ == "__main__":
    sys.exit(main())
