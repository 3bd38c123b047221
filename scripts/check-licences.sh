#!/usr/bin/env bash
# Fails when a program links anything GPL-only: GPL or AGPL without a linking exception (LGPL, "GPL with the GCC
# Runtime Library exception" and dual licences with a non-GPL choice are fine; THIRD_PARTY.md explains why).
# Usage: scripts/check-licences.sh [-v] BINARY...
#   Shared libraries: each one `ldd BINARY` resolves, mapped to its Debian package (dpkg -S) and that package's
#   /usr/share/doc/<package>/copyright.
#   Static parts, when BINARY was built in a CMake build tree (BUILD/bin/NAME, Makefile or Ninja generator): the link
#   line of NAME gives the project's static libraries and any system archive; the build's dependency records of
#   those objects give every system header compiled into the binary (header-only libraries: Boost, nlohmann-json,
#   CLI11, gemmi, ...). A header is judged by its own SPDX-License-Identifier
#   line when it has one (Linux's "GPL-2.0 WITH Linux-syscall-note"), else by its package's copyright file.
#   A package's licence is the "Files: *" stanza of a machine-readable copyright file (the other stanzas cover
#   build scripts, tests and examples, not the library), or, for a free-form file, GPL-only when it names the GPL
#   and neither the LGPL nor an exception.
# -v prints every dependency with its licence. Exit: 0 clean, 1 a GPL-only dependency or one whose licence cannot be
# read (one line each on stderr), 2 usage or an unreadable binary, 77 no dpkg (nothing to map libraries to).
set -euo pipefail

verbose=false
if [[ ${1:-} == -v ]]; then verbose=true; shift; fi
if (($# == 0)); then echo "usage: check-licences.sh [-v] BINARY..." >&2; exit 2; fi
if ! command -v dpkg >/dev/null || ! command -v dpkg-query >/dev/null; then
  echo "check-licences: dpkg is not installed; skipped" >&2
  exit 77
fi

# GPL-only for a licence expression ("GPL-2+", "Expat and BSL-1", "GPL-2+ or LGPL-3+", "GPL-3+ with GCC-Runtime-
# Library exception", "GPL-2.0 WITH Linux-syscall-note"): true when every alternative has a GPL/AGPL part without
# an exception.
declare -A expression_verdict
gpl_only_expression() {
  local expression=${1,,} alternative part gpl_part verdict=yes
  if [[ -n ${expression_verdict[$expression]:-} ]]; then [[ ${expression_verdict[$expression]} == yes ]]; return; fi
  local normalised=${expression//-or-later/+}  # SPDX "GPL-3.0-or-later"; Debian's "GPL-2+-or-X11" is a choice
  normalised=${normalised//-or-/ or }
  normalised=${normalised//[()]/ }
  local -a alternatives parts
  mapfile -t alternatives <<<"${normalised// or /$'\n'}"
  for alternative in "${alternatives[@]}"; do
    [[ -z ${alternative// /} ]] && continue
    # "GPL-3.0-or-later OR LicenseRef-Commercial" (CGAL): a licence to buy is no choice a free package has.
    [[ $alternative =~ (commercial|proprietary) ]] && continue
    gpl_part=false
    mapfile -t parts <<<"${alternative// and /$'\n'}"
    for part in "${parts[@]}"; do
      [[ $part =~ (^|[^l])gpl && ! $part =~ (exception|[[:space:]]with[[:space:]]) ]] && gpl_part=true
    done
    $gpl_part || verdict=no
  done
  expression_verdict[$expression]=$verdict
  [[ $verdict == yes ]]
}

# The main licence of a package, from its copyright file: "Files: *" stanza of the machine-readable format, else
# the first stanza's; "free-form" for the older format (judged by free_form_gpl_only).
declare -A package_licence
licence_of_package() {
  local package=$1 file="/usr/share/doc/$1/copyright" licence
  if [[ -n ${package_licence[$package]:-} ]]; then echo "${package_licence[$package]}"; return; fi
  if [[ ! -r $file ]]; then
    licence="no copyright file"
  elif head -n 1 "$file" | grep -q '^Format:'; then
    licence=$(awk '/^Files:[[:space:]]*\*[[:space:]]*$/ {star = 1} star && /^License:/ {sub(/^License:[[:space:]]*/, ""); print; exit}' "$file")
    [[ -z $licence ]] && licence=$(awk '/^Files:/ {files = 1} files && /^License:/ {sub(/^License:[[:space:]]*/, ""); print; exit}' "$file")
    [[ -z $licence ]] && licence="unstated"
  elif grep -qiE 'Lesser General Public|Library General Public|\bLGPL|exception' "$file"; then
    licence="free-form copyright naming the LGPL or an exception"
  else
    licence="free-form copyright"
  fi
  package_licence[$package]=$licence
  echo "$licence"
}

free_form_gpl_only() {
  local file="/usr/share/doc/$1/copyright"
  grep -qiE 'General Public Licen[cs]e|\bGPL\b' "$file" &&
    ! grep -qiE 'Lesser General Public|Library General Public|\bLGPL|exception' "$file"
}

# Prints the package's licence; returns 0 when it is GPL-only, 1 when not, 2 when it cannot be read (no copyright
# file, say, as in images that drop /usr/share/doc): an unknown licence fails the check like a GPL-only one.
package_is_gpl_only() {
  local package=$1 licence
  licence=$(licence_of_package "$package")
  echo "$licence"
  case $licence in
    free-form*) free_form_gpl_only "$package" ;;
    "no copyright file" | unstated) return 2 ;;
    *) gpl_only_expression "$licence" ;;
  esac
}

# The package owning PATH (dpkg -S); also tries the path with symlinks resolved and the /usr-merged twin.
package_of() {
  local path=$1 candidate owner
  for candidate in "$path" "$(realpath -m "$path")" "/usr$path" "${path#/usr}"; do
    [[ -z $candidate || $candidate != /* ]] && continue
    owner=$(dpkg -S "$candidate" 2>/dev/null | grep -v '^diversion' | head -n 1 | cut -d: -f1) || true
    if [[ -n $owner ]]; then echo "${owner%%,*}"; return 0; fi
  done
  return 1
}

failures=0
report() {  # report BINARY WHAT PACKAGE LICENCE yes|no|unknown (GPL-only?)
  case $5 in
    yes) echo "check-licences: $1: $2 ($3): $4, GPL without a linking exception" >&2; failures=$((failures + 1)) ;;
    unknown) echo "check-licences: $1: $2 ($3): licence unknown ($4)" >&2; failures=$((failures + 1)) ;;
    *) if $verbose; then printf '  %-36s %-22s %s\n' "$2" "$3" "$4"; fi ;;
  esac
}

# report BINARY WHAT PACKAGE with the package's licence.
judge_package() {
  local licence status=0 verdicts=(yes no unknown)
  licence=$(package_is_gpl_only "$3") || status=$?
  report "$1" "$2" "$3" "$licence" "${verdicts[status]}"
}

check_shared_libraries() {
  local binary=$1 library package
  while read -r library; do
    [[ -z $library ]] && continue
    if ! package=$(package_of "$library"); then
      echo "check-licences: $binary: $library belongs to no Debian package" >&2
      failures=$((failures + 1))
      continue
    fi
    judge_package "$binary" "$(basename "$library")" "$package"
  done < <(ldd "$binary" | awk '$2 == "=>" && $3 ~ /^\// {print $3} $1 ~ /^\// {print $1}' | sort -u)
}

# Packages whose copyright file names a GPL that does not reach programs using their headers, said elsewhere by
# the upstream: linux-libc-dev holds only the kernel's userspace API headers (`make headers_install`), which the
# kernel's COPYING puts under the Linux-syscall-note ("does not cover user programs that use kernel services by
# normal system calls"); most of them also carry that SPDX line, the generated ones (asm/unistd_64.h) carry none.
declare -A header_exception=([linux-libc-dev]="GPL-2.0 WITH Linux-syscall-note")

# "HEADER<TAB>SPDX expression" for each header (first 40 lines) that has an SPDX-License-Identifier line.
spdx_of_headers() {
  xargs -r -d '\n' awk 'FNR == 1 {seen = 0}
    !seen && FNR <= 40 && match($0, /SPDX-License-Identifier:[ \t]*/) {
      id = substr($0, RSTART + RLENGTH); sub(/[ \t]*\*\/.*$/, "", id); sub(/[ \t]+$/, "", id)
      print FILENAME "\t" id; seen = 1; nextfile }'
}

# The CMake build tree BINARY was built in (BUILD/bin/NAME), or nothing.
build_tree_of() {
  local build
  build=$(dirname "$(dirname "$(realpath "$1")")")
  [[ -f $build/CMakeCache.txt ]] && echo "$build"
}

# What BINARY (built in the tree BUILD) holds statically, one "archive PATH" or "header PATH" per line: the system
# archives of its link line, and the system headers of its objects and of the project's libraries' objects. Makefile
# trees keep the link line in CMakeFiles/NAME.dir/link.txt and the headers in the compilers' dependency files
# (*.o.d); Ninja trees keep both in ninja's own records (-t commands, -t inputs, -t deps). Prints nothing for a
# binary the tree does not build.
static_inputs() {
  local binary=$1 build=$2 name token
  name=$(basename "$binary")
  if grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja' "$build/CMakeCache.txt"; then
    local target
    target=$(realpath --relative-to="$build" "$binary")
    ninja -C "$build" -t query "$target" >/dev/null 2>&1 || return 0
    for token in $(ninja -C "$build" -t commands "$target" | tail -n 1); do
      [[ $token == /usr/*.a ]] && echo "archive $token"
    done
    ninja -C "$build" -t inputs "$target" | grep '\.o$' | (cd "$build" && xargs -r ninja -t deps) |
      sed -n 's/^ *\(\/usr\/.*\)$/header \1/p'
    return
  fi
  local link_txt target_dir link_dir archive
  link_txt=$(find "$build" -path "*/CMakeFiles/$name.dir/link.txt" -print -quit)
  [[ -n $link_txt ]] || return 0
  target_dir=$(dirname "$link_txt")
  link_dir=$(dirname "$(dirname "$target_dir")")
  local object_dirs=("$target_dir") object_deps=()
  for token in $(cat "$link_txt"); do
    if [[ $token == *.o ]]; then  # an object of the link line (an OBJECT library's too): its dependency file
      object_deps+=("$(cd "$link_dir" && realpath -m "$token").d")
      continue
    fi
    [[ $token == *.a ]] || continue
    archive=$(cd "$link_dir" && realpath -m "$token")
    if [[ $archive == /usr/* ]]; then
      echo "archive $archive"
    else  # the project's own library libNAME.a: its objects' dependency files
      archive=$(dirname "$archive")/CMakeFiles/$(basename "$archive" .a | sed 's/^lib//').dir
      [[ -d $archive ]] && object_dirs+=("$archive")
    fi
  done
  { find "${object_dirs[@]}" -name '*.o.d' -exec cat {} +; ((${#object_deps[@]} == 0)) || cat "${object_deps[@]}" 2>/dev/null; } | tr ' \\' '\n\n' |
    sed -n 's/:$//; /^\/usr\//s/^/header /p'
}

check_static_parts() {
  local binary=$1 build inputs archive headers header package spdx
  build=$(build_tree_of "$binary") || return 0
  inputs=$(static_inputs "$binary" "$build")
  [[ -n $inputs ]] || return 0
  while read -r archive; do
    package=$(package_of "$archive") || { echo "check-licences: $binary: $archive belongs to no package" >&2; failures=$((failures + 1)); continue; }
    judge_package "$binary" "$(basename "$archive")" "$package"
  done < <(sed -n 's/^archive //p' <<<"$inputs")
  headers=$(sed -n 's/^header //p' <<<"$inputs" | xargs -r realpath -m -s | sort -u)
  if [[ -z $headers ]]; then
    echo "check-licences: $binary: no dependency records in $build (build the binary first)" >&2
    failures=$((failures + 1))
    return
  fi
  # Header -> package through dpkg's own file lists (what dpkg -S reads), in one pass for thousands of headers.
  local -A header_package header_spdx judged
  while IFS=$'\t' read -r package header; do
    header_package[$header]=$package
  done < <(awk 'FNR == NR {wanted[$0] = 1; next} ($0 in wanted) {n = FILENAME; sub(/.*\//, "", n); sub(/\.list$/, "", n); sub(/:.*/, "", n); print n "\t" $0}' \
             <(echo "$headers") /var/lib/dpkg/info/*.list)
  while IFS=$'\t' read -r header spdx; do
    header_spdx[$header]=$spdx
  done < <(spdx_of_headers <<<"$headers")
  while read -r header; do
    package=${header_package[$header]:-}
    if [[ -z $package ]] && ! package=$(package_of "$header"); then
      echo "check-licences: $binary: header $header belongs to no package" >&2
      failures=$((failures + 1))
      continue
    fi
    spdx=${header_spdx[$header]:-${header_exception[$package]:-}}
    if [[ -n $spdx ]]; then
      if gpl_only_expression "$spdx"; then
        # One line per package (CGAL has hundreds of such headers): the first one names the case.
        [[ -n ${judged["$package gpl"]:-} ]] && continue
        judged["$package gpl"]=1
        report "$binary" "headers of $package such as $header" "$package" "$spdx" yes
      elif [[ -z ${judged["$package spdx"]:-} ]]; then
        judged["$package spdx"]=1
        report "$binary" "headers of $package" "$package" "$spdx (per header)" no
      fi
      continue
    fi
    [[ -n ${judged[$package]:-} ]] && continue
    judged[$package]=1
    judge_package "$binary" "headers of $package" "$package"
  done <<<"$headers"
}

for binary in "$@"; do
  if [[ ! -r $binary ]] || ! ldd "$binary" >/dev/null 2>&1; then
    echo "check-licences: $binary: not a dynamically linked executable or library" >&2
    exit 2
  fi
  $verbose && echo "$binary:"
  check_shared_libraries "$binary"
  check_static_parts "$binary"
done
if ((failures > 0)); then exit 1; fi
$verbose && echo "check-licences: no GPL-only dependency in $*"
exit 0
