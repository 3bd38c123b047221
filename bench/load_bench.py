#!/usr/bin/env python3
"""Load benchmark of tracemeshd (make bench-load): mixed requests at a fixed concurrency against the real server.

Kinds (share of the requests):
  cache_hit  40%  POST /mesh of a molecule meshed before the run (gly, adp, fas2 at density 1): a cache hit
  small      25%  POST /mesh of gly or adp at a random density and t0 (mostly new jobs)
  bad_input  20%  a PQR line with a missing column, a negative radius, density=abc, no file part: a 4xx
  slow_body  15%  POST /mesh of adp whose body arrives in 8 pieces over ~SLOW_SECONDS
Every request runs on its own connection (Connection: close), timed from connect to the last response byte. The
requests come from CLIENTS loopback addresses in turn (127.0.0.2, 127.0.0.3, ...; a lab's users, so the per-client
limits see several clients, not one; only against a loopback server). Like curl, a client whose write fails still
reads the response (a refused upload is answered before its body is read).
Prints a Markdown table (per kind: count, statuses, p50, p99, max in ms). Exit status 1 when any response is a
5xx, or no complete response arrived, or a kind got a status class it must never get (bad_input 2xx, others
4xx other than 408/429), so the benchmark is a test too. Standard library only (Debian's python3).

Usage: load_bench.py --daemon build/bin/tracemeshd [--molecules DIR] [--requests 1000] [--concurrency 64]
                     [--seed N] [--slow-seconds 1.0] [--clients 16]
                     [--url http://host:port (an already running server)]
"""
import argparse
import asyncio
import contextlib
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time

BOUNDARY = "tracemesh-load-bench"
KIND_SHARES = [("cache_hit", 40), ("small", 25), ("bad_input", 20), ("slow_body", 15)]


def multipart(pqr: bytes, fields: dict, with_file: bool = True) -> bytes:
    out = b""
    for name, value in fields.items():
        out += (f"--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"{name}\"\r\n\r\n{value}\r\n").encode()
    if with_file:
        out += (f"--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"pqr\"; filename=\"mol.pqr\"\r\n"
                "Content-Type: application/octet-stream\r\n\r\n").encode() + pqr + b"\r\n"
    return out + f"--{BOUNDARY}--\r\n".encode()


def post(target: str, body: bytes, host: str) -> tuple:
    head = (f"POST {target} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n"
            f"Content-Type: multipart/form-data; boundary={BOUNDARY}\r\nContent-Length: {len(body)}\r\n\r\n")
    return head.encode(), body


class Plan:
    """The seeded list of requests: (kind, head, body)."""

    def __init__(self, molecules: str, requests: int, seed: int, host: str):
        read = lambda name: open(os.path.join(molecules, name), "rb").read()
        self.pqr = {name: read(name) for name in ("gly.pqr", "adp.pqr", "fas2.pqr")}
        self.host = host
        rng = random.Random(seed)
        kinds = [k for k, share in KIND_SHARES for _ in range(share)]
        self.requests = [self.make(rng.choice(kinds), rng) for _ in range(requests)]

    def warm_up(self):
        return [post("/mesh", multipart(pqr, {"density": "1"}), self.host) for pqr in self.pqr.values()]

    def make(self, kind: str, rng: random.Random):
        if kind == "cache_hit":
            return (kind, *post("/mesh", multipart(rng.choice(list(self.pqr.values())), {"density": "1"}), self.host))
        if kind in ("small", "slow_body"):
            name = rng.choice(["gly.pqr", "adp.pqr"]) if kind == "small" else "adp.pqr"
            fields = {"density": rng.choice(["1", "1.5", "2", "3"]), "t0": rng.choice(["0.5", "1", "1.5"])}
            return (kind, *post("/mesh", multipart(self.pqr[name], fields), self.host))
        gly_lines = self.pqr["gly.pqr"].decode().splitlines(keepends=True)
        atom = next(i for i, line in enumerate(gly_lines) if line.startswith(("ATOM", "HETATM")))
        missing_column = gly_lines[:]
        missing_column[atom] = " ".join(missing_column[atom].split()[:-1]) + "\n"
        negative_radius = gly_lines[:]
        fields = negative_radius[atom].split()
        negative_radius[atom] = " ".join(fields[:-1] + ["-" + fields[-1]]) + "\n"
        bodies = [multipart("".join(missing_column).encode(), {}),
                  multipart("".join(negative_radius).encode(), {}),
                  multipart(self.pqr["gly.pqr"], {"density": "abc"}),
                  multipart(b"", {"density": "1"}, with_file=False)]
        return (kind, *post("/mesh", rng.choice(bodies), self.host))


async def exchange(host: str, port: int, head: bytes, body: bytes, pieces: int, slow_seconds: float,
                   client: str = None):
    """One request on a fresh connection from address `client` (None: any): (status or 0, seconds). The body is
    sent in `pieces` spread over slow_seconds when pieces > 1."""
    start = time.monotonic()
    try:
        local = (client, 0) if client else None
        reader, writer = await asyncio.open_connection(host, port, local_addr=local)
        try:
            writer.write(head)
            step = max(1, -(-len(body) // pieces))
            for offset in range(0, len(body), step):
                writer.write(body[offset:offset + step])
                await writer.drain()
                if pieces > 1 and offset + step < len(body):
                    await asyncio.sleep(slow_seconds / pieces)
        except OSError:
            pass  # answered and closed before the whole body was sent: the answer is still to be read
        response = await asyncio.wait_for(reader.read(), timeout=600)
        writer.close()
        match = re.match(rb"HTTP/1\.[01] (\d{3})", response)
        return (int(match.group(1)) if match else 0), time.monotonic() - start
    except (OSError, asyncio.TimeoutError):
        return 0, time.monotonic() - start


def percentile(sorted_values, fraction):
    if not sorted_values:
        return float("nan")
    index = min(len(sorted_values) - 1, max(0, int(round(fraction * len(sorted_values) + 0.5)) - 1))
    return sorted_values[index]


def allowed(kind: str, status: int) -> bool:
    if status == 0 or status >= 500:
        return False
    if kind == "bad_input":
        return 400 <= status < 500
    return 200 <= status < 300 or status in (408, 429)


def start_daemon(daemon: str, workdir: str):
    log_path = os.path.join(workdir, "server.log")
    log = open(log_path, "w")
    process = subprocess.Popen([daemon, "--listen", "127.0.0.1:0", "--cache-dir", os.path.join(workdir, "cache")],
                               stdout=log, stderr=subprocess.STDOUT)
    for _ in range(1000):
        for line in open(log_path):
            if '"event":"started"' in line:
                return process, json.loads(line)["port"], log_path
        if process.poll() is not None:
            break
        time.sleep(0.01)
    process.kill()
    sys.exit("load_bench: tracemeshd did not start:\n" + open(log_path).read())


@contextlib.contextmanager
def target_server(url, daemon: str, workdir_prefix: str):
    """The server a benchmark loads, as (host, port, process): the one at `url` (process None), else a tracemeshd
    started in a temporary folder, whose error lines are counted and which is stopped when the block ends."""
    workdir = tempfile.mkdtemp(prefix=workdir_prefix)
    process = None
    try:
        if url:
            match = re.match(r"http://([^:/]+):(\d+)", url)
            if not match:
                sys.exit("--url expects http://host:port")
            yield match.group(1), int(match.group(2)), None
        else:
            process, port, log_path = start_daemon(daemon, workdir)
            yield "127.0.0.1", port, process
            errors = [line for line in open(log_path) if '"level":"error"' in line]
            if errors:
                print(f"server logged {len(errors)} error lines, first: {errors[0].strip()}", file=sys.stderr)
    finally:
        if process is not None:
            process.terminate()
            process.wait(timeout=60)
        shutil.rmtree(workdir, ignore_errors=True)


async def run(args, host: str, port: int):
    plan = Plan(args.molecules, args.requests, args.seed, f"{host}:{port}")
    for head, body in plan.warm_up():
        status, _ = await exchange(host, port, head, body, 1, 0)
        if status != 200:
            sys.exit(f"load_bench: warm-up request answered {status}")
    limit = asyncio.Semaphore(args.concurrency)
    results = []
    clients = [f"127.0.0.{2 + n}" for n in range(args.clients)] if host.startswith("127.") else [None]

    async def one(number, kind, head, body):
        async with limit:
            pieces = 8 if kind == "slow_body" else 1
            client = clients[number % len(clients)]
            status, seconds = await exchange(host, port, head, body, pieces, args.slow_seconds, client)
            results.append((kind, status, seconds))

    wall = time.monotonic()
    await asyncio.gather(*(one(number, *request) for number, request in enumerate(plan.requests)))
    return results, time.monotonic() - wall


def report(results, wall_seconds, args) -> int:
    print(f"{len(results)} requests, {args.concurrency} concurrent from {args.clients} clients, seed {args.seed}, "
          f"{wall_seconds:.1f} s wall\n")
    print("| kind | requests | 2xx | 4xx | 5xx | no reply | p50 ms | p99 ms | max ms |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    failures = []
    for kind, _ in KIND_SHARES + [("all", 0)]:
        rows = [r for r in results if kind == "all" or r[0] == kind]
        times = sorted(r[2] * 1000 for r in rows)
        count = lambda low, high: sum(1 for r in rows if low <= r[1] < high)
        print(f"| {kind} | {len(rows)} | {count(200, 300)} | {count(400, 500)} | {count(500, 600)} | "
              f"{count(0, 1)} | {percentile(times, 0.5):.0f} | {percentile(times, 0.99):.0f} | "
              f"{(times[-1] if times else 0):.0f} |")
        if kind != "all":
            failures += [f"{kind}: status {r[1]}" for r in rows if not allowed(kind, r[1])]
    statuses = {}
    for _, status, _ in results:
        statuses[status] = statuses.get(status, 0) + 1
    print(f"\nstatuses: {dict(sorted(statuses.items()))}")
    if failures:
        print(f"load_bench: FAILED, {len(failures)} responses not allowed: {sorted(set(failures))}", file=sys.stderr)
        return 1
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--daemon", default="build/bin/tracemeshd")
    parser.add_argument("--molecules", default=os.environ.get("TRACEMESH_MOLECULES_DIR",
                        os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "molecules")))
    parser.add_argument("--requests", type=int, default=1000)
    parser.add_argument("--concurrency", type=int, default=64)
    parser.add_argument("--seed", type=int, default=12)
    parser.add_argument("--slow-seconds", type=float, default=1.0)
    parser.add_argument("--clients", type=int, default=16, help="loopback client addresses (1 to 250)")
    parser.add_argument("--url", help="an already running server, http://host:port")
    args = parser.parse_args()
    if not 1 <= args.clients <= 250:
        parser.error("--clients must be within 1 to 250")
    with target_server(args.url, args.daemon, "tracemesh-load-") as (host, port, _):
        results, wall = asyncio.run(run(args, host, port))
        return report(results, wall, args)

if __name__ == "__main__":
    sys.exit(main())
