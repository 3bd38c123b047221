#!/usr/bin/env bash
# `systemd-analyze verify` accepts the installed tracemeshd.service (its ExecStart names the installed tracemeshd,
# its Documentation= the installed man page), and the unit has the settings the service relies on: a dynamic user,
# state and cache directories, the sandboxing, restarts, and a stop timeout longer than tracemeshd's shutdown grace.
# Usage: systemd_unit_test.sh PREFIX  (after package.install_tree); exit 77 without systemd-analyze.
set -uo pipefail
prefix=$1
unit=$prefix/lib/systemd/system/tracemeshd.service
fail() { echo "systemd_unit_test: $*" >&2; exit 1; }
command -v systemd-analyze >/dev/null || { echo "systemd_unit_test: no systemd-analyze; skipped"; exit 77; }
[[ -s $unit ]] || fail "$unit is missing (package.install_tree installs it)"
output=$(MANPATH=$prefix/share/man systemd-analyze verify "$unit" 2>&1) || fail "systemd-analyze verify failed: $output"
[[ -z $output ]] || fail "systemd-analyze verify warns: $output"
for setting in DynamicUser=yes StateDirectory=tracemeshd CacheDirectory=tracemeshd ProtectSystem=strict \
               ProtectHome=yes NoNewPrivileges=yes PrivateTmp=yes Restart=on-failure KillSignal=SIGTERM; do
  grep -qx "$setting" "$unit" || fail "the unit lacks $setting"
done
grace=$(sed -n 's/^ExecStart=.*--shutdown-grace \([0-9]*\).*/\1/p' "$unit")
timeout=$(sed -n 's/^TimeoutStopSec=\([0-9]*\)$/\1/p' "$unit")
[[ -n $grace && -n $timeout ]] || fail "the unit sets no --shutdown-grace or TimeoutStopSec"
((timeout > grace)) || fail "TimeoutStopSec=$timeout does not exceed --shutdown-grace $grace: systemd would kill draining jobs"
grep -q -- '--cache-dir /var/cache/tracemeshd' "$unit" || fail "the unit's --cache-dir is not /var/cache/tracemeshd"
echo "systemd-analyze verify accepts $unit (grace $grace s, stop timeout $timeout s)"
