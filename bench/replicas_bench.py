#!/usr/bin/env python3
"""Scaling-out benchmark (make bench-replicas): tracemeshd replicas sharing Redis and one result directory
(`--store redis://…`) behind nginx (docker/nginx's replicas upstream), as real processes on loopback ports.

1. Throughput: the same mixed stream of asynchronous jobs (the ladder fas2 … 1k4r_5asu of $TRACEMESH_MOLECULES_DIR, each at
   the given densities) is sent at once through nginx to 1 and then to 2 replicas, each replica pinned to a core of
   its own (taskset), with one worker and one mesher thread; every run starts from an empty Redis and an empty result
   directory. Reports jobs per minute (jobs ÷ time from the first POST to the last job done) and the p50/p99 of the
   job latency (POST to done, polled every 50 ms).
2. Cache hits: GET /jobs/{id}/mesh?format=off of a done job with wrk (-t1 -c16, --duration seconds), through nginx to
   2 replicas vs one replica directly.
Prints Markdown tables. Needs redis-server, nginx, taskset and wrk (scripts/install-deps.sh installs them).

Usage: replicas_bench.py --daemon build/bin/tracemeshd [--molecules DIR]
                         [--ladder fas2.pqr,mache.pqr,...] [--densities 1,1.2] [--replicas 1,2] [--duration 5]
"""
import argparse
import json
import os
import re
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LADDER = ("fas2.pqr,mache.pqr,achbp.pqr,3j6r_asu.pqr,1ihm_asu.pqr,2buk_12asu.pqr,1k4r_5asu.pqr.gz")
BOUNDARY = "tracemesh-replicas-bench"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until(condition, seconds: float, what: str):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    sys.exit(f"replicas_bench: {what} did not happen within {seconds} s")


def http(url: str, data: bytes = None, headers: dict = None, timeout: float = 30):
    request = urllib.request.Request(url, data=data, headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=timeout) as reply:
            return reply.status, reply.read()
    except urllib.error.HTTPError as error:
        return error.code, error.read()
    except OSError:
        return 0, b""


def multipart(pqr: bytes, fields: dict) -> bytes:
    out = b""
    for name, value in fields.items():
        out += f"--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"{name}\"\r\n\r\n{value}\r\n".encode()
    out += (f"--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"pqr\"; filename=\"mol.pqr\"\r\n"
            "Content-Type: application/octet-stream\r\n\r\n").encode() + pqr + b"\r\n"
    return out + f"--{BOUNDARY}--\r\n".encode()


class Cluster:
    """redis-server (append-only file on), N pinned replicas on one result directory, nginx in front."""

    def __init__(self, args, work: str, replicas: int):
        self.work = os.path.join(work, f"x{replicas}")
        os.makedirs(os.path.join(self.work, "shared"))
        self.procs = []
        self.redis_port = free_port()
        self.spawn(["redis-server", "--port", str(self.redis_port), "--bind", "127.0.0.1", "--save", "",
                    "--appendonly", "yes", "--appendfsync", "always", "--dir", self.work], "redis.log")
        wait_until(lambda: self.redis_ping(), 10, "redis-server start")
        self.ports = []
        for i in range(replicas):
            port = free_port()
            self.spawn(["taskset", "-c", str(i % os.cpu_count()), args.daemon, "--listen", f"127.0.0.1:{port}",
                        "--cache-dir", os.path.join(self.work, "shared"), "--store",
                        f"redis://127.0.0.1:{self.redis_port}", "--replica-name", f"r{i + 1}", "--workers", "1",
                        "--small-job-workers", "0", "--mesher-threads", "1", "--max-queue", "1000",
                        "--log-level", "warn"], f"r{i + 1}.log")
            wait_until(lambda: http(f"http://127.0.0.1:{port}/readyz")[0] == 200, 20, f"replica r{i + 1} start")
            self.ports.append(port)
        self.nginx_port = self.start_nginx()

    def spawn(self, argv, log):
        self.procs.append(subprocess.Popen(argv, stdout=open(os.path.join(self.work, log), "wb"),
                                           stderr=subprocess.STDOUT))

    def redis_ping(self) -> bool:
        try:
            with socket.create_connection(("127.0.0.1", self.redis_port), timeout=0.2) as s:
                s.sendall(b"PING\r\n")
                return s.recv(16).startswith(b"+PONG")
        except OSError:
            return False

    def start_nginx(self) -> int:
        conf = os.path.join(REPO, "docker", "nginx")
        d = os.path.join(self.work, "nginx")
        os.makedirs(d)
        upstream = open(os.path.join(conf, "upstream-replicas.conf")).read()
        upstream = re.sub(r"\n\s*server tracemesh-\d+:8080[^\n]*", "", upstream)
        servers = "".join(f"\n    server 127.0.0.1:{p} max_fails=1 fail_timeout=10s;" for p in self.ports)
        upstream = upstream.replace("least_conn;", "least_conn;" + servers)
        open(os.path.join(d, "upstream.conf"), "w").write(upstream)
        port = free_port()
        server = open(os.path.join(conf, "tracemesh.conf")).read()
        server = server.replace("listen 80;", f"listen 127.0.0.1:{port};")
        server = server.replace("/etc/nginx/tracemesh/upstream.conf", os.path.join(d, "upstream.conf"))
        server = server.replace("/etc/nginx/tracemesh/proxy.conf", os.path.join(conf, "proxy.conf"))
        open(os.path.join(d, "server.conf"), "w").write(server)
        user = "user root root;\n" if os.geteuid() == 0 else ""
        open(os.path.join(d, "nginx.conf"), "w").write(
            f"{user}worker_processes 1;\npid {d}/nginx.pid;\nerror_log {d}/error.log;\n"
            f"events {{ worker_connections 1024; }}\nhttp {{\n  access_log off;\n"
            f"  client_body_temp_path {d}/body; proxy_temp_path {d}/proxy; fastcgi_temp_path {d}/fastcgi;\n"
            f"  uwsgi_temp_path {d}/uwsgi; scgi_temp_path {d}/scgi;\n  include {d}/server.conf;\n}}\n")
        nginx = shutil.which("nginx") or "/usr/sbin/nginx"
        self.spawn([nginx, "-p", d, "-c", os.path.join(d, "nginx.conf"), "-g", "daemon off;"], "nginx.log")
        wait_until(lambda: http(f"http://127.0.0.1:{port}/healthz")[0] == 200, 10, "nginx start")
        return port

    def stop(self):
        for proc in reversed(self.procs):
            proc.terminate()
        for proc in self.procs:
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def percentile(values, q):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


def run_stream(cluster: Cluster, jobs) -> dict:
    """Submits every job through nginx at once, then polls each until done; latency and throughput."""
    base = f"http://127.0.0.1:{cluster.nginx_port}"
    started = time.monotonic()
    submitted = {}
    for name, pqr, density in jobs:
        status, body = http(base + "/jobs", multipart(pqr, {"density": density}),
                            {"Content-Type": f"multipart/form-data; boundary={BOUNDARY}"}, timeout=120)
        if status not in (200, 202):
            sys.exit(f"replicas_bench: POST /jobs {name} answered {status}: {body[:200]!r}")
        submitted[json.loads(body)["id"]] = (name, time.monotonic())
    latencies, last_done = {}, started
    while len(latencies) < len(submitted):
        for job_id, (name, sent) in submitted.items():
            if job_id in latencies:
                continue
            status, body = http(f"{base}/jobs/{job_id}")
            state = json.loads(body).get("status") if status == 200 else None
            if state in ("failed", "cancelled"):
                sys.exit(f"replicas_bench: job {name} ended {state}: {body[:300]!r}")
            if state == "done":
                last_done = time.monotonic()
                latencies[job_id] = last_done - sent
        time.sleep(0.05)
    ran = {}
    for i, port in enumerate(cluster.ports):
        _, text = http(f"http://127.0.0.1:{port}/metrics")
        found = re.search(rf'tracemesh_replica_jobs_total{{replica="r{i + 1}",how="taken"}} (\d+)', text.decode())
        ran[f"r{i + 1}"] = int(found.group(1)) if found else 0
    seconds = last_done - started
    values = list(latencies.values())
    return {"jobs": len(values), "seconds": seconds, "per_minute": 60 * len(values) / seconds,
            "p50": percentile(values, 0.5), "p99": percentile(values, 0.99), "ran": ran,
            "done_id": next(iter(submitted))}


def wrk(url: str, duration: int) -> dict:
    out = subprocess.run(["wrk", "-t1", "-c16", f"-d{duration}s", "--latency", url], capture_output=True,
                         text=True, check=True).stdout

    def ms(label):
        found = re.search(rf"^\s+{label}%\s+([\d.]+)(us|ms|s)\s*$", out, re.M)
        value, unit = float(found.group(1)), found.group(2)
        return value / 1000 if unit == "us" else value * 1000 if unit == "s" else value

    return {"rps": float(re.search(r"Requests/sec:\s+([\d.]+)", out).group(1)), "p50": ms("50"), "p99": ms("99")}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--daemon", required=True)
    parser.add_argument("--molecules", default=os.environ.get("TRACEMESH_MOLECULES_DIR", os.path.join(REPO, "tests", "data", "molecules")))
    parser.add_argument("--ladder", default=LADDER)
    parser.add_argument("--densities", default="1,1.2")
    parser.add_argument("--replicas", default="1,2")
    parser.add_argument("--duration", type=int, default=5)
    args = parser.parse_args()
    for tool in ("redis-server", "taskset", "wrk"):
        if not shutil.which(tool):
            sys.exit(f"replicas_bench: {tool} is not installed (scripts/install-deps.sh)")
    pqr = {name: open(os.path.join(args.molecules, name), "rb").read() for name in args.ladder.split(",")}
    jobs = [(name, pqr[name], density) for density in args.densities.split(",") for name in pqr]
    work = tempfile.mkdtemp(prefix="tracemesh-replicas-bench-")
    rows, hits = [], None
    try:
        for count in (int(n) for n in args.replicas.split(",")):
            cluster = Cluster(args, work, count)
            try:
                result = run_stream(cluster, jobs)
                rows.append((count, result))
                print(f"replicas_bench: {count} replica(s): {result}", file=sys.stderr)
                if count == max(int(n) for n in args.replicas.split(",")):
                    target = f"/jobs/{result['done_id']}/mesh?format=off"
                    http(f"http://127.0.0.1:{cluster.nginx_port}{target}")  # encoded once, then cached
                    hits = {"through nginx": wrk(f"http://127.0.0.1:{cluster.nginx_port}{target}", args.duration),
                            "one replica directly": wrk(f"http://127.0.0.1:{cluster.ports[0]}{target}",
                                                        args.duration)}
            finally:
                cluster.stop()
    finally:
        shutil.rmtree(work, ignore_errors=True)

    print(f"\nMixed stream: {len(jobs)} jobs ({args.ladder.replace(',', ', ')}; densities {args.densities}), "
          "one core, one worker and one mesher thread per replica\n")
    print("| replicas | jobs | seconds | jobs/min | p50 s | p99 s | jobs run per replica |")
    print("|---:|---:|---:|---:|---:|---:|---|")
    for count, r in rows:
        ran = ", ".join(f"{k} {v}" for k, v in r["ran"].items())
        print(f"| {count} | {r['jobs']} | {r['seconds']:.1f} | {r['per_minute']:.2f} | {r['p50']:.1f} | "
              f"{r['p99']:.1f} | {ran} |")
    if hits:
        print(f"\nCache-hit GET /jobs/{{id}}/mesh?format=off (wrk -t1 -c16 -d{args.duration}s)\n")
        print("| path | requests/s | p50 ms | p99 ms |\n|---|---:|---:|---:|")
        for path, h in hits.items():
            print(f"| {path} | {h['rps']:,.0f} | {h['p50']:.2f} | {h['p99']:.2f} |")


if __name__ == "__main__":
    main()
