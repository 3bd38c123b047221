#!/usr/bin/env bash
# `cmake --install BUILD_DIR --prefix PREFIX` into an empty PREFIX: the programs, both man pages, the docs
# (README.md, LICENSE, THIRD_PARTY.md, and whatever CHANGELOG.md, docs/*.md and docs/images/ the source tree has
# now), the systemd unit naming PREFIX's tracemeshd and defaults file, and that defaults file. Leaves PREFIX for
# package.systemd_unit.
# Usage: install_tree_test.sh SOURCE_DIR BUILD_DIR PREFIX
set -uo pipefail
source_dir=$1 build_dir=$2 prefix=$3
fail() { echo "install_tree_test: $*" >&2; exit 1; }
rm -rf "$prefix"
output=$(cmake --install "$build_dir" --prefix "$prefix" 2>&1) || fail "cmake --install failed: $output"

for program in tracemesh tracemeshd; do
  [[ -x $prefix/bin/$program ]] || fail "$prefix/bin/$program is not installed"
  "$prefix/bin/$program" --version >/dev/null || fail "the installed $program does not run"
done
[[ -s $prefix/share/man/man1/tracemesh.1 ]] || fail "share/man/man1/tracemesh.1 is not installed"
[[ -s $prefix/share/man/man8/tracemeshd.8 ]] || fail "share/man/man8/tracemeshd.8 is not installed"
if command -v man >/dev/null; then
  for page in tracemesh tracemeshd; do
    man -M "$prefix/share/man" -w "$page" >/dev/null 2>&1 || fail "man -M $prefix/share/man -w $page finds no page"
  done
fi
docs=(README.md LICENSE THIRD_PARTY.md copyright)
shopt -s nullglob
for doc in "$source_dir"/CHANGELOG.md "$source_dir"/docs/*.md "$source_dir"/docs/images/*; do
  docs+=("${doc#"$source_dir"/}")
done
shopt -u nullglob
for doc in "${docs[@]}"; do
  [[ -s $prefix/share/doc/tracemesh/$doc ]] || fail "share/doc/tracemesh/$doc is not installed"
done

unit=$prefix/lib/systemd/system/tracemeshd.service
[[ -s $unit ]] || fail "lib/systemd/system/tracemeshd.service is not installed"
grep -qx "ExecStart=$prefix/bin/tracemeshd .*" "$unit" || fail "the unit does not start $prefix/bin/tracemeshd: $(grep ExecStart= "$unit")"
grep -qx "EnvironmentFile=-$prefix/etc/default/tracemeshd" "$unit" \
  || fail "the unit does not read $prefix/etc/default/tracemeshd: $(grep EnvironmentFile= "$unit")"
grep -q '^TRACEMESHD_LISTEN=' "$prefix/etc/default/tracemeshd" || fail "etc/default/tracemeshd sets no TRACEMESHD_LISTEN"
echo "installed into $prefix: 2 programs, 2 man pages, ${#docs[@]} documents, the unit and its defaults"
