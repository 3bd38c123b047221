#!/usr/bin/env bash
# scripts/check-licences.sh passes tracemesh and tracemeshd, and flags real GPL-only links: a system program
# linked to GNU readline (GPL-3+) and, when given, further binaries with the package they must name.
# Usage: licences_test.sh CHECK_SCRIPT --programs BINARY... [--gpl-linked BINARY PACKAGE]...
# Exit 77 without dpkg (the check cannot map libraries to packages there).
set -uo pipefail
check=$1; shift
programs=(); gpl_binaries=(); gpl_packages=()
while (($#)); do
  case $1 in
    --programs) shift; while (($#)) && [[ $1 != --* ]]; do programs+=("$1"); shift; done ;;
    --gpl-linked) gpl_binaries+=("$2"); gpl_packages+=("$3"); shift 3 ;;
    *) echo "licences_test: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
command -v dpkg >/dev/null || { echo "licences_test: no dpkg; skipped"; exit 77; }

fail() { echo "licences_test: $*" >&2; exit 1; }

output=$(bash "$check" -v "${programs[@]}" 2>&1) || fail "the programs have a GPL-only dependency:"$'\n'"$output"
echo "$output"

# The system's users of libreadline.so.8 (bc, sqlite3, gpg, gdb, Python's readline module): the first one present.
for candidate in /usr/bin/bc /usr/bin/sqlite3 /usr/bin/gpg /usr/bin/gdb /usr/lib/python3*/lib-dynload/readline*.so; do
  if [[ -e $candidate ]] && ldd "$candidate" 2>/dev/null | grep -q 'libreadline\.so'; then
    gpl_binaries+=("$candidate"); gpl_packages+=(libreadline8)
    break
  fi
done
((${#gpl_binaries[@]})) || fail "no GPL-linked binary to prove the check on (install bc, or build cgal_tests)"
for i in "${!gpl_binaries[@]}"; do
  binary=${gpl_binaries[$i]} package=${gpl_packages[$i]}
  flagged=$(bash "$check" "$binary" 2>&1)
  status=$?
  ((status == 1)) || fail "$binary links $package (GPL-only) but the check exited $status: $flagged"
  grep -q "($package)" <<<"$flagged" || fail "$binary: the check did not name $package: $flagged"
  echo "flagged as it must be: $flagged"
done
