#!/usr/bin/env bash
# tracemeshd benchmark (loopback, one run):
#  1. cache hits: wrk against GET /jobs/{id}/mesh?format=draco for the mache Draco mesh, side by side with nginx
#     serving the same bytes as a static file (both with one worker/I-O thread);
#  2. jobs per minute for a stream of distinct small molecules (gly and adp with distinct t0), and the service
#     overhead per job: client wall time of a synchronous POST /mesh minus the job's run time on its worker
#     ("seconds" of GET /jobs/{id}: meshing, encoding and cache writes) — i.e. upload, PQR parsing, hashing,
#     queue hand-off, completion callback and response.
# Usage: bash bench/server_bench.sh [BUILD_DIR]   (needs wrk, nginx, curl, jq; tracemeshd built in BUILD_DIR)
# Knobs: DURATION (wrk seconds, 10), CONNECTIONS (32), THREADS (2), JOBS (40), PARALLEL (2).
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${1:-$ROOT/build}
DAEMON=$BUILD/bin/tracemeshd
MOLECULES=${TRACEMESH_MOLECULES_DIR:-$ROOT/../shared/molecules}
DURATION=${DURATION:-10}
CONNECTIONS=${CONNECTIONS:-32}
THREADS=${THREADS:-2}
JOBS=${JOBS:-40}
PARALLEL=${PARALLEL:-2}

for tool in wrk nginx curl jq; do
  command -v "$tool" > /dev/null || { echo "server_bench: $tool is required" >&2; exit 1; }
done
[ -x "$DAEMON" ] || { echo "server_bench: build tracemeshd first ($DAEMON)" >&2; exit 1; }

WORK=$(mktemp -d)
DAEMON_PID=""
NGINX_PID=""
cleanup() {
  [ -n "$DAEMON_PID" ] && kill "$DAEMON_PID" 2> /dev/null && wait "$DAEMON_PID" 2> /dev/null || true
  [ -n "$NGINX_PID" ] && kill "$NGINX_PID" 2> /dev/null || true
  rm -rf "$WORK"
}
trap cleanup EXIT

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

start_daemon() {
  local port=$1
  "$DAEMON" --listen "127.0.0.1:$port" --cache-dir "$WORK/cache" --io-threads 1 --workers "$PARALLEL" \
    --max-queue 1000 --log-level warn 2> "$WORK/daemon.log" &
  DAEMON_PID=$!
  for _ in $(seq 200); do curl -sf "http://127.0.0.1:$port/healthz" > /dev/null && return; sleep 0.05; done
  echo "server_bench: tracemeshd did not start" >&2; cat "$WORK/daemon.log" >&2; exit 1
}

# wrk's summary → "rps p50 p99" (latencies in ms).
wrk_summary() {
  wrk -t"$THREADS" -c"$CONNECTIONS" -d"${DURATION}s" --latency "$1" > "$WORK/wrk.txt"
  awk '
    function ms(v) { if (v ~ /us$/) return v / 1000; if (v ~ /ms$/) return v + 0; if (v ~ /s$/) return v * 1000; return v }
    /Requests\/sec/ { rps = $2 }
    $1 == "50%" { p50 = ms($2) }
    $1 == "99%" { p99 = ms($2) }
    /Non-2xx/ { bad = $NF }
    END { printf "%.0f %.2f %.2f %s\n", rps, p50, p99, (bad == "" ? 0 : bad) }' "$WORK/wrk.txt"
}

DAEMON_PORT=$(free_port)
NGINX_PORT=$(free_port)
start_daemon "$DAEMON_PORT"
BASE="http://127.0.0.1:$DAEMON_PORT"

# ---- 1. cache hits vs nginx ----------------------------------------------------------------------------------
echo "meshing mache (8,279 atoms) once ..."
curl -sf -D "$WORK/mache.hdr" -o "$WORK/mache.drc" -F "pqr=@$MOLECULES/mache.pqr" -F format=draco "$BASE/mesh"
JOB=$(tr -d '\r' < "$WORK/mache.hdr" | awk -F': ' 'tolower($1) == "x-job-id" { print $2 }')
mkdir -p "$WORK/www"
cp "$WORK/mache.drc" "$WORK/www/mache.drc"
chmod -R a+rX "$WORK"  # nginx workers run as an unprivileged user
cat > "$WORK/nginx.conf" << CONF
worker_processes 1;
daemon off;
pid $WORK/nginx.pid;
error_log $WORK/nginx-error.log;
events { worker_connections 1024; }
http {
  access_log off;
  sendfile on;
  keepalive_requests 100000;
  types { application/vnd.google.draco drc; }
  server { listen 127.0.0.1:$NGINX_PORT; root $WORK/www; }
}
CONF
nginx -c "$WORK/nginx.conf" -p "$WORK" &
NGINX_PID=$!
for _ in $(seq 100); do curl -sf "http://127.0.0.1:$NGINX_PORT/mache.drc" -o /dev/null && break; sleep 0.05; done
cmp -s "$WORK/mache.drc" <(curl -sf "$BASE/jobs/$JOB/mesh?format=draco") || { echo "cache hit bytes differ" >&2; exit 1; }

SIZE=$(stat -c %s "$WORK/mache.drc")
read -r D_RPS D_P50 D_P99 D_BAD < <(wrk_summary "$BASE/jobs/$JOB/mesh?format=draco")
read -r N_RPS N_P50 N_P99 N_BAD < <(wrk_summary "http://127.0.0.1:$NGINX_PORT/mache.drc")
kill "$NGINX_PID" 2> /dev/null || true
wait "$NGINX_PID" 2> /dev/null || true
NGINX_PID=""

echo
echo "## Cache hit of the mache Draco mesh ($SIZE bytes), wrk -t$THREADS -c$CONNECTIONS -d${DURATION}s, loopback"
echo
echo "| server | requests/s | p50 ms | p99 ms | non-2xx |"
echo "|---|---:|---:|---:|---:|"
echo "| tracemeshd (1 I/O thread) | $D_RPS | $D_P50 | $D_P99 | $D_BAD |"
echo "| nginx (1 worker, sendfile) | $N_RPS | $N_P50 | $N_P99 | $N_BAD |"
awk -v d="$D_RPS" -v n="$N_RPS" 'BEGIN { printf "\ntracemeshd / nginx throughput: %.0f %% (target >= 50 %%)\n", 100 * d / n }'

# ---- 2. a stream of distinct small molecules ------------------------------------------------------------------
echo
echo "## $JOBS distinct small jobs (gly, adp; distinct t0), $PARALLEL at a time, $PARALLEL workers"
job() {
  local i=$1 mol t0
  mol=$([ $((i % 2)) -eq 0 ] && echo gly || echo adp)
  t0=$(awk -v i="$i" 'BEGIN { printf "%.4f", 0.5 + i * 0.01 }')
  # client wall seconds, job id
  curl -sf -o /dev/null -D "$WORK/job$i.hdr" -w '%{time_total}' -F "pqr=@$MOLECULES/$mol.pqr" -F "t0=$t0" \
    "$BASE/mesh" > "$WORK/job$i.time"
}
export -f job
export WORK MOLECULES BASE
START=$(date +%s.%N)
seq 0 $((JOBS - 1)) | xargs -P "$PARALLEL" -I{} bash -c 'job {}'
END=$(date +%s.%N)
OVERHEADS=$WORK/overheads
: > "$OVERHEADS"
for i in $(seq 0 $((JOBS - 1))); do
  id=$(tr -d '\r' < "$WORK/job$i.hdr" | awk -F': ' 'tolower($1) == "x-job-id" { print $2 }')
  job_seconds=$(curl -sf "$BASE/jobs/$id" | jq '.seconds')
  awk -v wall="$(cat "$WORK/job$i.time")" -v job="$job_seconds" 'BEGIN { printf "%.3f\n", (wall - job) * 1000 }' \
    >> "$OVERHEADS"
done
awk -v start="$START" -v end="$END" -v jobs="$JOBS" 'BEGIN { printf "jobs per minute: %.0f (%.2f s for %d jobs)\n", jobs * 60 / (end - start), end - start, jobs }'
sort -n "$OVERHEADS" | awk '{ v[NR] = $1; s += $1 } END { printf "overhead per job (client wall - job time), ms: mean %.2f, p50 %.2f, max %.2f (target < 5)\n", s / NR, v[int((NR + 1) / 2)], v[NR] }'
echo "mesher runs: $(curl -sf "$BASE/metrics" | awk '$1 == "tracemesh_mesher_runs_total" { print $2 }')"
