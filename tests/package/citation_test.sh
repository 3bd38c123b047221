#!/usr/bin/env bash
# CITATION.cff: CFF 1.2.0, Apache-2.0, the project version of CMakeLists.txt, and the TMSmesh paper's DOI.
# Usage: citation_test.sh CITATION.cff PROJECT_VERSION
set -uo pipefail
file=$1 version=$2
fail() { echo "citation_test: $file: $*" >&2; exit 1; }
field() { sed -n "s/^$1:[[:space:]]*//p" "$file" | head -n 1; }
[[ $(field cff-version) == 1.2.0 ]] || fail "cff-version is '$(field cff-version)', not 1.2.0"
[[ $(field title) == tracemesh ]] || fail "title is '$(field title)', not tracemesh"
[[ $(field license) == Apache-2.0 ]] || fail "license is '$(field license)', not Apache-2.0"
[[ $(field version) == "$version" ]] || fail "version is '$(field version)', CMakeLists.txt says $version"
grep -q 'doi: 10.1021/ct100376g' "$file" || fail "the TMSmesh paper (doi 10.1021/ct100376g) is not cited"
if python3 -c 'import yaml' 2>/dev/null; then
  python3 -c 'import sys, yaml; yaml.safe_load(open(sys.argv[1]))' "$file" || fail "is not valid YAML"
fi
echo "CITATION.cff: tracemesh $version, Apache-2.0, cites doi 10.1021/ct100376g"
