#!/usr/bin/env bash
# The Debian package installed and used in a clean Debian 12 (`make test-package`, after `make package`).
# Makes a minimal bookworm root (debootstrap --variant=minbase, from the mirror of this machine's apt sources; the
# pristine root is cached as BUILD_DIR/package-test/bookworm-minbase.tar, so a second run skips debootstrap),
# installs BUILD_DIR/tracemesh_*.deb there with apt-get (its Depends resolved from the mirror, so they are proven
# complete), then in that root: meshes tests/data/molecules/fas2.pqr with /usr/bin/tracemesh (exit 0, the report
# says closed and certified: no boundary or non-manifold edge); starts /usr/bin/tracemeshd with the command line of the installed systemd unit on a
# free loopback port as an unprivileged user, POSTs fas2 to /mesh (200, an OFF mesh), stops it with SIGTERM (exit 0);
# checks the man pages, the unit and the conffile /etc/default/tracemeshd; removes and purges the package.
# Usage: tests/package/install_test.sh BUILD_DIR     (as root: debootstrap and chroot need it)
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
build_dir=$(realpath "${1:?usage: install_test.sh BUILD_DIR}")
work=$build_dir/package-test
root=$work/root
cache=$work/bookworm-minbase.tar
started_at=$SECONDS
pid=""

step() { printf 'install_test: %s (%d s)\n' "$*" $((SECONDS - started_at)); }
fail() {
  printf 'install_test: FAIL: %s\n' "$*" >&2
  if [[ -s $work/tracemeshd.log ]]; then echo "--- tracemeshd log (last 20 lines):" >&2; tail -20 "$work/tracemeshd.log" >&2; fi
  exit 1
}
in_root() { chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin DEBIAN_FRONTEND=noninteractive "$@"; }

unmount_root() {
  local mounted_dir
  for mounted_dir in "$root/proc" "$root/dev"; do
    if mountpoint -q "$mounted_dir" && ! umount "$mounted_dir"; then
      return 1  # never rm -rf through a bind mount of the host's /dev
    fi
  done
}
cleanup() {
  if [[ -n $pid ]]; then kill -KILL "$pid" 2>/dev/null || true; wait "$pid" 2>/dev/null || true; fi
  if unmount_root; then rm -rf "$root"; else echo "install_test: could not unmount under $root; left in place" >&2; fi
}

(($(id -u) == 0)) || fail "needs root (debootstrap, chroot)"
for tool in debootstrap chroot curl tar; do
  command -v "$tool" >/dev/null || fail "$tool is not installed (apt-get install $tool)"
done
shopt -s nullglob
debs=("$build_dir"/tracemesh_*.deb)
shopt -u nullglob
((${#debs[@]} == 1)) || fail "expected one tracemesh_*.deb in $build_dir, found ${#debs[@]} (run make package)"
deb=${debs[0]}
step "package $(basename "$deb")"

# ---- the mirror and suites of this machine's apt sources (one-line .list and deb822 .sources) ----
# Prints "URI SUITE" for each bookworm suite with the main component.
host_suites() {
  local file
  for file in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [[ -r $file ]] || continue
    sed 's/\[[^]]*\]//' "$file" | awk '$1 == "deb" && $3 ~ /^bookworm/ {for (i = 4; i <= NF; ++i) if ($i == "main") print $2, $3}'
  done
  for file in /etc/apt/sources.list.d/*.sources; do
    [[ -r $file ]] || continue
    awk 'function flush() { if (deb && main) for (s in suites) for (u in uris) if (suites[s] ~ /^bookworm/) print uris[u], suites[s]
                            deb = main = 0; delete uris; delete suites }
         /^[[:space:]]*$/ {flush(); next}
         /^#/ {next}
         $1 == "Types:" {for (i = 2; i <= NF; ++i) if ($i == "deb") deb = 1}
         $1 == "URIs:" {for (i = 2; i <= NF; ++i) uris[i] = $i}
         $1 == "Suites:" {for (i = 2; i <= NF; ++i) suites[i] = $i}
         $1 == "Components:" {for (i = 2; i <= NF; ++i) if ($i == "main") main = 1}
         END {flush()}' "$file"
  done
}
mapfile -t suites < <(host_suites | sort -u)
((${#suites[@]})) || fail "no bookworm 'main' source in /etc/apt/sources.list or /etc/apt/sources.list.d/"
mirror=""
for entry in "${suites[@]}"; do
  [[ ${entry#* } == bookworm ]] && mirror=${entry% *}
done
[[ -n $mirror ]] || fail "no mirror of the bookworm suite itself among: ${suites[*]}"

# ---- a clean bookworm root: the cached pristine one, or debootstrap ----
mkdir -p "$work"
trap cleanup EXIT
unmount_root || fail "a previous run left mounts under $root"
rm -rf "$root" "$work/tracemeshd.log"
mkdir -p "$root"
if [[ -s $cache && $(cat "$cache.mirror" 2>/dev/null) == "$mirror" ]]; then
  tar -C "$root" -xf "$cache" || fail "cannot unpack the cached root $cache"
  step "clean root from the cache $cache"
else
  step "debootstrap --variant=minbase bookworm from $mirror (cached for the next run)"
  debootstrap --variant=minbase bookworm "$root" "$mirror" >"$work/debootstrap.log" 2>&1 \
    || fail "debootstrap failed (log: $work/debootstrap.log): $(tail -n 1 "$work/debootstrap.log")"
  tar -C "$root" -cf "$cache.partial" . && mv "$cache.partial" "$cache" && echo "$mirror" >"$cache.mirror"
  step "debootstrap done"
fi
for entry in "${suites[@]}"; do echo "deb ${entry% *} ${entry#* } main"; done >"$root/etc/apt/sources.list"
cp /etc/resolv.conf "$root/etc/resolv.conf" 2>/dev/null || true
mount -t proc proc "$root/proc"
mount --bind /dev "$root/dev"

# ---- apt-get install ./tracemesh_*.deb: Depends come from the mirror ----
in_root apt-get update -qq >"$work/apt.log" 2>&1 || fail "apt-get update in the root failed: $(tail -n 2 "$work/apt.log")"
cp "$deb" "$root/tmp/"
if ! in_root sh -c "cd /tmp && apt-get install -y -q --no-install-recommends ./$(basename "$deb")" >>"$work/apt.log" 2>&1; then
  fail "apt-get install ./$(basename "$deb") failed: $(grep -E '^(E:|dpkg:| )' "$work/apt.log" | tail -n 3 | tr '\n' ' ')"
fi
step "installed with its Depends: $(in_root dpkg-query -W -f '${Depends}' tracemesh)"

# ---- the files: programs, man pages, unit, conffile, docs ----
for file in /usr/bin/tracemesh /usr/bin/tracemeshd; do
  [[ -x $root$file ]] || fail "$file is not installed"
done
for page in /usr/share/man/man1/tracemesh.1 /usr/share/man/man8/tracemeshd.8; do
  [[ -s $root$page || -s $root$page.gz ]] || fail "man page $page is not installed"
done
unit=/usr/lib/systemd/system/tracemeshd.service
[[ -s $root$unit ]] || fail "$unit is not installed"
[[ -s $root/etc/default/tracemeshd ]] || fail "/etc/default/tracemeshd is not installed"
in_root dpkg-query -W -f '${Conffiles}' tracemesh | grep -q '/etc/default/tracemeshd' \
  || fail "/etc/default/tracemeshd is not a conffile of the package"
for doc in copyright LICENSE THIRD_PARTY.md README.md; do
  [[ -s $root/usr/share/doc/tracemesh/$doc ]] || fail "/usr/share/doc/tracemesh/$doc is not installed"
done
version=$(in_root /usr/bin/tracemesh --version) || fail "tracemesh --version failed: $version"
step "files in place; $version"

# ---- tracemesh meshes fas2 ----
cp "$repo/tests/data/molecules/fas2.pqr" "$root/tmp/fas2.pqr"
in_root /usr/bin/tracemesh /tmp/fas2.pqr -o /tmp/fas2.off --report /tmp/fas2.json >"$work/tracemesh.log" 2>&1 \
  || fail "tracemesh fas2.pqr exited $?: $(tail -n 1 "$work/tracemesh.log")"
[[ $(head -c 3 "$root/tmp/fas2.off") == OFF ]] || fail "tracemesh wrote no OFF mesh"
report=$(tr -d ' \n' <"$root/tmp/fas2.json")
[[ $report == *'"certified":true'* ]] || fail "the fas2 report is not certified: $(head -c 300 "$root/tmp/fas2.json")"
# Closed: the certificate counts no boundary edge and no non-manifold edge.
[[ $report =~ \"boundary_edges\":0[,}] && $report =~ \"non_manifold_edges\":0[,}] ]] \
  || fail "the fas2 mesh is not closed: $(grep -E 'boundary_edges|non_manifold_edges' "$root/tmp/fas2.json" | tr -d ' \n')"
step "tracemesh fas2.pqr: a closed, certified OFF mesh"

# ---- tracemeshd with the unit's command line, as an unprivileged user, on a free loopback port ----
exec_start=$(sed -n 's/^ExecStart=//p' "$root$unit")
[[ -n $exec_start ]] || fail "$unit has no ExecStart"
# systemd's expansion with the defaults file's values: the listen address replaced, TRACEMESHD_OPTIONS empty.
read -r -a words <<<"$exec_start"
command=()
for word in "${words[@]}"; do
  case $word in
    '${TRACEMESHD_LISTEN}') command+=(127.0.0.1:0) ;;
    '$TRACEMESHD_OPTIONS') ;;
    *) command+=("$word") ;;
  esac
done
user=nobody group=nogroup
# What systemd does for StateDirectory= and CacheDirectory=.
install -d -o "$user" -g "$group" "$root/var/lib/tracemeshd" "$root/var/cache/tracemeshd"
chroot --userspec="$user:$group" "$root" "${command[@]}" --workers 1 >"$work/tracemeshd.log" 2>&1 &
pid=$!
port=""
for _ in $(seq 200); do  # the "started" log line names the port (a poll for that event, 20 s at most)
  port=$(grep '"started"' "$work/tracemeshd.log" | sed -n 's/.*"port":\([0-9]*\).*/\1/p' | head -n 1) || true
  [[ -n $port ]] && break
  kill -0 "$pid" 2>/dev/null || fail "tracemeshd exited at start: $(tail -n 1 "$work/tracemeshd.log")"
  sleep 0.1
done
[[ -n $port ]] || fail "tracemeshd logged no 'started' line within 20 s"
step "tracemeshd (${command[*]}) listens on 127.0.0.1:$port"
code=$(curl -s -o "$work/fas2_served.off" -w '%{http_code}' -F pqr=@"$repo/tests/data/molecules/fas2.pqr" \
         "http://127.0.0.1:$port/mesh") || fail "POST /mesh: no answer"
[[ $code == 200 ]] || fail "POST /mesh fas2 answered $code: $(head -c 300 "$work/fas2_served.off")"
[[ $(head -c 3 "$work/fas2_served.off") == OFF ]] || fail "POST /mesh fas2 did not return an OFF mesh"
step "POST /mesh fas2: 200, an OFF mesh"
kill -TERM "$pid"
status=0
wait "$pid" || status=$?
pid=""
((status == 0)) || fail "tracemeshd exited $status after SIGTERM, not 0"
step "SIGTERM: tracemeshd exited 0"

# ---- remove and purge: the maintainer scripts never fail without systemd ----
in_root apt-get remove -y -q tracemesh >>"$work/apt.log" 2>&1 || fail "apt-get remove tracemesh failed: $(tail -n 2 "$work/apt.log")"
[[ ! -e $root/usr/bin/tracemeshd && -e $root/etc/default/tracemeshd ]] \
  || fail "apt-get remove must remove the programs and keep the conffile"
in_root apt-get purge -y -q tracemesh >>"$work/apt.log" 2>&1 || fail "apt-get purge tracemesh failed: $(tail -n 2 "$work/apt.log")"
[[ ! -e $root/etc/default/tracemeshd ]] || fail "apt-get purge left /etc/default/tracemeshd"
step "removed (conffile kept) and purged; PASS in $((SECONDS - started_at)) s"
