#!/usr/bin/env bash
# Issue 12, finding 10: does a small job pass big ones? Starts tracemeshd with two general workers, submits two
# capsid jobs (POST /jobs), waits until both run, then times a synchronous POST /mesh of fas2 (906 atoms) and
# checks the capsids are still running when it returns. Runs twice: with the small-job lane (--small-job-workers 1,
# the default) and without it (--small-job-workers 0), each on a fresh cache.
# Usage: bash bench/small_job_bench.sh [BUILD_DIR]   (needs curl, jq; tracemeshd built in BUILD_DIR)
# Knobs: BIG (the capsid file in the molecules dir, 2buk_capsid.pqr.gz), WORKERS (2). Target: fas2 within 2 s.
# Timings are only meaningful on a quiet machine.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${1:-$ROOT/build}
DAEMON=$BUILD/bin/tracemeshd
MOLECULES=${TRACEMESH_MOLECULES_DIR:-$ROOT/../shared/molecules}
BIG=${BIG:-2buk_capsid.pqr.gz}
WORKERS=${WORKERS:-2}

for tool in curl jq; do
  command -v "$tool" > /dev/null || { echo "small_job_bench: $tool is required" >&2; exit 1; }
done
[ -x "$DAEMON" ] || { echo "small_job_bench: build tracemeshd first ($DAEMON)" >&2; exit 1; }

WORK=$(mktemp -d)
DAEMON_PID=""
cleanup() {
  [ -n "$DAEMON_PID" ] && kill "$DAEMON_PID" 2> /dev/null && wait "$DAEMON_PID" 2> /dev/null || true
  rm -rf "$WORK"
}
trap cleanup EXIT

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

run_case() {
  local lane=$1 port
  port=$(free_port)
  rm -rf "$WORK/cache"
  "$DAEMON" --listen "127.0.0.1:$port" --cache-dir "$WORK/cache" --workers "$WORKERS" --small-job-workers "$lane" \
    --log-level warn 2> "$WORK/daemon.log" &
  DAEMON_PID=$!
  for _ in $(seq 200); do curl -sf "http://127.0.0.1:$port/healthz" > /dev/null && break; sleep 0.05; done
  local base="http://127.0.0.1:$port" ids=() t0
  # Two distinct capsid jobs (t0 differs, so they are two jobs, not one coalesced).
  for t0 in 1.0 1.01; do
    ids+=("$(curl -sf -F "structure=@$MOLECULES/$BIG" -F "t0=$t0" "$base/jobs" | jq -r .id)")
  done
  for _ in $(seq 600); do
    local running=0
    for id in "${ids[@]}"; do
      [ "$(curl -sf "$base/jobs/$id" | jq -r .status)" = running ] && running=$((running + 1))
    done
    [ "$running" -ge "$WORKERS" ] || [ "$running" -ge 2 ] && break
    sleep 0.1
  done
  local start end
  start=$(date +%s.%N)
  curl -sf -o /dev/null -F "structure=@$MOLECULES/fas2.pqr" "$base/mesh"
  end=$(date +%s.%N)
  local states=""
  for id in "${ids[@]}"; do states+="$(curl -sf "$base/jobs/$id" | jq -r .status) "; done
  printf "small-job-workers=%s  fas2 POST /mesh: %.2f s  capsid jobs then: %s\n" "$lane" \
    "$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')" "$states"
  kill "$DAEMON_PID"; wait "$DAEMON_PID" 2> /dev/null || true; DAEMON_PID=""
}

echo "big: $BIG, $WORKERS general workers, $(nproc) cores"
run_case 1
run_case 0
