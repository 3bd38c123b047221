#!/usr/bin/env bash
# Smoke test of the tracemesh container image (`make test-image`; not part of `make test`: the image build compiles
# the whole project). The image's own entry point runs in a chroot of the image's filesystem as the image's user
# (podman/docker `run` cannot start containers in this sandbox: setrlimit is forbidden), which checks what matters:
# the runtime stage has every library, the user exists, paths and permissions are right, the service answers.
# Checks: image config (non-root user 10001, volume, STOPSIGNAL, HEALTHCHECK), the volume folder's owner, /healthz
# and the image's HEALTHCHECK command, POST /mesh of fas2 → 200 + an OFF mesh whose job report is certified, the
# process's uid/gid, cache and job files written in the volume, docker/nginx in front (tests/image/nginx_check.sh),
# SIGTERM while a job runs → clean exit (0) within the grace, and a restart re-queues that job from the volume.
# Usage: tests/image/smoke_test.sh [IMAGE]   (default localhost/tracemesh:latest; ENGINE=docker|podman)
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
image=${1:-localhost/tracemesh:latest}
uid=10001 gid=10001
volume=/var/lib/tracemesh
grace=1                 # --shutdown-grace given to tracemeshd here
stop_margin=5           # seconds past the grace allowed for cancelling, flushing responses and exiting
molecules=$repo/tests/data/molecules  # fas2.pqr, kept in the repository
# shellcheck source=../../scripts/container-engine.sh
. "$repo/scripts/container-engine.sh"

step() { printf 'smoke: %s\n' "$*"; }
fail() { printf 'smoke: FAIL: %s\n' "$*" >&2; [[ -s ${work:-/nonexistent}/tracemeshd.log ]] && { echo "--- tracemeshd log (last 20 lines):" >&2; tail -20 "$work/tracemeshd.log" >&2; }; exit 1; }

work=$(mktemp -d /tmp/tracemesh-smoke.XXXXXX)
root=$work/root
pid=""
cleanup() {
  [[ -n $pid ]] && { kill -KILL "$pid" 2>/dev/null; wait "$pid" 2>/dev/null; } || true
  local mounted_dir
  for mounted_dir in "$root/proc" "$root/dev"; do
    if mountpoint -q "$mounted_dir" && ! umount "$mounted_dir"; then
      # Never rm -rf through a bind mount of the host's /dev.
      echo "smoke: could not unmount $mounted_dir; $work left in place" >&2
      return
    fi
  done
  rm -rf "$work"
}
trap cleanup EXIT

# ---- the image's configuration ----
"$ENGINE" image inspect "$image" >/dev/null 2>&1 || fail "image $image not found (run make image)"
# docker keeps HEALTHCHECK in .Config.Healthcheck, podman beside it in .Healthcheck: one object with both.
config=$("$ENGINE" image inspect "$image" | jq '.[0] | .Config + {Healthcheck: (.Config.Healthcheck // .Healthcheck)}')
[[ $(jq -r .User <<<"$config") == "$uid:$gid" ]] || fail "image user is '$(jq -r .User <<<"$config")', expected $uid:$gid"
jq -e --arg v "$volume" '.Volumes | has($v)' <<<"$config" >/dev/null || fail "image declares no VOLUME $volume"
[[ $(jq -r .StopSignal <<<"$config") == SIGTERM ]] || fail "image STOPSIGNAL is not SIGTERM"
jq -e '.Healthcheck.Test | length > 0' <<<"$config" >/dev/null \
  || fail "image has no HEALTHCHECK (podman needs --format docker to keep it)"
mapfile -t entrypoint < <(jq -r '.Entrypoint[]' <<<"$config")
mapfile -t healthcheck < <(jq -r '.Healthcheck.Test[1:][]' <<<"$config")
step "image config: user $uid:$gid, volume $volume, STOPSIGNAL SIGTERM, HEALTHCHECK ${healthcheck[*]}"

# ---- a writable copy of the image's filesystem ----
mkdir -p "$root"
if [[ $ENGINE == podman ]]; then
  mounted=$(podman image mount "$image")
  cp -a "$mounted/." "$root/"
  podman image unmount "$image" >/dev/null
else
  container=$(docker create "$image")
  docker export "$container" | tar -x -C "$root"
  docker rm -v "$container" >/dev/null  # -v: and the anonymous volume create made
fi
[[ $(stat -c %u:%g "$root$volume") == "$uid:$gid" ]] \
  || fail "$volume is owned by $(stat -c %u:%g "$root$volume"), not $uid:$gid: a fresh volume would not be writable"
# What a container has: /proc (TBB reads the CPU set there) and /dev (null, urandom).
mount -t proc proc "$root/proc"
mount --bind /dev "$root/dev"

# ---- start the image's entry point as its user, on a free loopback port ----
args=()
for ((i = 1; i < ${#entrypoint[@]}; ++i)); do
  if [[ ${entrypoint[i - 1]} == --listen ]]; then args+=("127.0.0.1:0"); else args+=("${entrypoint[i]}"); fi
done
step "starting ${entrypoint[0]} ${args[*]} as $uid:$gid"
chroot --userspec="$uid:$gid" "$root" "${entrypoint[0]}" "${args[@]}" --shutdown-grace "$grace" --workers 1 \
  >"$work/tracemeshd.log" 2>&1 &
pid=$!
port=""
for _ in $(seq 100); do
  port=$(grep -h '"started"' "$work/tracemeshd.log" 2>/dev/null | jq -r '.port // empty' 2>/dev/null | head -1 || true)
  [[ -n $port ]] && break
  kill -0 "$pid" 2>/dev/null || fail "tracemeshd exited at start (missing library or unwritable $volume?)"
  sleep 0.2
done
[[ -n $port ]] || fail "tracemeshd logged no 'started' line within 20 s"
base=http://127.0.0.1:$port

# ---- it runs as the image's user ----
[[ $(cat "/proc/$pid/comm") == tracemeshd ]] || fail "pid $pid is $(cat "/proc/$pid/comm"), not tracemeshd"
read -r _ ruid euid suid fsuid < <(grep '^Uid:' "/proc/$pid/status")
read -r _ rgid egid sgid fsgid < <(grep '^Gid:' "/proc/$pid/status")
for id in "$ruid" "$euid" "$suid" "$fsuid"; do [[ $id == "$uid" ]] || fail "tracemeshd runs with uid $id, expected $uid"; done
for id in "$rgid" "$egid" "$sgid" "$fsgid"; do [[ $id == "$gid" ]] || fail "tracemeshd runs with gid $id, expected $gid"; done
step "tracemeshd (pid $pid) listens on port $port with uid $uid and gid $gid"

# ---- health ----
code=$(curl -s -o /dev/null -w '%{http_code}' "$base/healthz") || fail "GET /healthz: no answer"
[[ $code == 200 ]] || fail "GET /healthz answered $code"
TRACEMESH_HEALTH_PORT=$port chroot --userspec="$uid:$gid" "$root" "${healthcheck[@]}" \
  || fail "the image's HEALTHCHECK command (${healthcheck[*]}) failed against a healthy server"
step "/healthz 200; the HEALTHCHECK command passes"

# ---- a real molecule ----
code=$(curl -s -D "$work/headers" -o "$work/fas2.off" -w '%{http_code}' -F pqr=@"$molecules/fas2.pqr" "$base/mesh") \
  || fail "POST /mesh: no answer"
[[ $code == 200 ]] || fail "POST /mesh fas2 answered $code: $(head -c 300 "$work/fas2.off")"
[[ $(head -c 3 "$work/fas2.off") == OFF ]] || fail "POST /mesh fas2 did not return an OFF mesh"
job=$(tr -d '\r' <"$work/headers" | awk -F': ' 'tolower($1) == "x-job-id" {print $2}')
[[ -n $job ]] || fail "POST /mesh answered without X-Job-Id"
curl -s "$base/jobs/$job" >"$work/job.json" || fail "GET /jobs/$job: no answer"
jq -e '.status == "done"' "$work/job.json" >/dev/null || fail "job $job is not done: $(head -c 300 "$work/job.json")"
jq -e '.report.certificate.certified == true' "$work/job.json" >/dev/null || fail "fas2's mesh report is not certified"
step "POST /mesh fas2: 200, $(sed -n 2p "$work/fas2.off" | cut -d' ' -f1-2) (vertices faces), report certified"

# ---- the volume holds the cache and the job store, written by the image's user ----
written=$(find "$root$volume" -type f | wc -l)
((written > 0)) || fail "nothing was written to $volume"
foreign=$(find "$root$volume" ! -user "$uid" | head -3)
[[ -z $foreign ]] || fail "files in $volume not owned by $uid: $foreign"
[[ -d $root$volume/jobs ]] || fail "no job store ($volume/jobs) in the volume"
step "$volume: $written files, all owned by $uid"

# ---- nginx in front: docker/nginx's plain and TLS configurations (tests/image/nginx_check.sh) ----
nginx_status=0
bash "$repo/tests/image/nginx_check.sh" --port "$port" || nginx_status=$?
case $nginx_status in
  0) ;;
  77) step "nginx or openssl missing: docker/nginx not checked (scripts/install-deps.sh --image installs them)" ;;
  *) fail "docker/nginx's configuration does not proxy tracemeshd (above)" ;;
esac

# ---- SIGTERM while a job runs past the grace: a clean exit within it; the job waits in the volume's job store ----
# achbp (16,090 atoms) at density 4 runs for many seconds (~4x mache at density 2, 4 s on a busy 2-core machine),
# far past the 1 s grace, so the grace is what stops it.
curl -s -o "$work/accepted.json" -F pqr=@"$molecules/achbp.pqr" "$base/jobs?density=4" || fail "POST /jobs: no answer"
long_job=$(jq -r '.id // empty' "$work/accepted.json")
[[ -n $long_job ]] || fail "POST /jobs achbp answered $(head -c 300 "$work/accepted.json")"
for _ in $(seq 100); do
  [[ $(curl -s "$base/jobs/$long_job" | jq -r .status) == running ]] && break
  sleep 0.1
done
started=$(date +%s.%N)
kill -TERM "$pid"
deadline=$((grace + stop_margin))
for _ in $(seq $((deadline * 10))); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
kill -0 "$pid" 2>/dev/null && fail "tracemeshd still runs $deadline s after SIGTERM (grace $grace s)"
status=0; wait "$pid" || status=$?
pid=""
seconds=$(awk -v a="$started" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
((status == 0)) || fail "tracemeshd exited with status $status after SIGTERM"
grep -q '"shutdown_done"' "$work/tracemeshd.log" || fail "tracemeshd logged no shutdown_done after SIGTERM"
drain=$(grep -h '"shutdown_started"' "$work/tracemeshd.log" | jq -r '"\(.running) running, \(.queued) queued"')
[[ $drain == "1 running, 0 queued" ]] || fail "the achbp job was not running at SIGTERM ($drain): the grace went untested"
step "SIGTERM with $drain: exit 0 after $seconds s (grace $grace s)"

# ---- a restart on the same volume takes the interrupted job up again ----
chroot --userspec="$uid:$gid" "$root" "${entrypoint[0]}" "${args[@]}" --workers 1 --shutdown-grace 0 \
  >"$work/restart.log" 2>&1 &
pid=$!
for _ in $(seq 100); do grep -q '"started"' "$work/restart.log" && break; sleep 0.1; done
grep -q '"jobs_requeued"' "$work/restart.log" || fail "the restart did not re-queue the interrupted job from $volume/jobs"
kill -TERM "$pid"; wait "$pid" || true; pid=""
step "restart on the same $volume: the interrupted job is queued again"
echo "smoke: all checks passed"
