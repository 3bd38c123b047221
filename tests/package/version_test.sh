#!/usr/bin/env bash
# `tracemesh --version` and `tracemeshd --version`: one line "<name> <version> (<engine version>, commit <commit>)"
# with the project version of CMake, the engine version of core/mesher.hpp and, in a git checkout, the commit of
# `git rev-parse --short HEAD` (else "unknown"). Exit 77 when HEAD was committed after the binary was built.
# Usage: version_test.sh SOURCE_DIR PROJECT_VERSION BINARY...
set -uo pipefail
source_dir=$1 version=$2; shift 2
fail() { echo "version_test: $*" >&2; exit 1; }

engine=$(sed -n 's/.*engine_version = "\([^"]*\)".*/\1/p' "$source_dir/core/mesher.hpp")
[[ -n $engine ]] || fail "no engine_version in $source_dir/core/mesher.hpp"
commit=unknown
if [[ -e $source_dir/.git ]] && command -v git >/dev/null; then
  commit=$(git -C "$source_dir" rev-parse --short HEAD) || fail "git rev-parse failed in $source_dir"
fi
for binary in "$@"; do
  name=$(basename "$binary")
  output=$("$binary" --version 2>&1) || fail "$name --version exited $?: $output"
  (($(wc -l <<<"$output") == 1)) || fail "$name --version printed more than one line: $output"
  expected="$name $version ($engine, commit $commit)"
  if [[ $output != "$expected" ]]; then
    printed=$(sed -n 's/.*, commit \([0-9a-f]*\))$/\1/p' <<<"$output")
    # HEAD committed after the binary was linked, and the binary names an ancestor of HEAD: it was built from an
    # earlier HEAD (other work committed since), which this run cannot tell from a wrong commit. Skipped, not passed.
    if [[ $commit != unknown && -n $printed && ${output%, commit *} == "${expected%, commit *}" ]] &&
       (($(git -C "$source_dir" log -1 --format=%ct HEAD) > $(stat -c %Y "$binary"))) &&
       git -C "$source_dir" merge-base --is-ancestor "$printed" HEAD 2>/dev/null; then
      echo "version_test: $name was built from $printed, HEAD $commit was committed after it: rebuild to check"
      exit 77
    fi
    fail "$name --version printed '$output', expected '$expected'"
  fi
  echo "$output"
done
