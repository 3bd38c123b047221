#!/usr/bin/env bash
# The README's picture (docs/images/viewer.png): the real web viewer in headless Chromium against a real tracemeshd,
# meshing a molecule of the suite and coloured by residue type, saved by tests/node/web_viewer_test.mjs.
#   scripts/readme_picture.sh [BUILD_DIR] [MOLECULE]     (defaults: build, mache.pqr)
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${1:-$repo/build}"
molecule="${2:-mache.pqr}"
out="$repo/docs/images/viewer.png"
if [[ ! -x "$build_dir/bin/tracemeshd" ]]; then
  echo "readme_picture.sh: no $build_dir/bin/tracemeshd (build it first: make build-run)" >&2
  exit 1
fi
mkdir -p "$(dirname "$out")"
node "$repo/tests/node/web_viewer_test.mjs" --tracemeshd "$build_dir/bin/tracemeshd" \
  --molecules "$repo/tests/data/molecules" --molecule "$molecule" --measure --colour residue --screenshot "$out"
echo "readme_picture.sh: wrote $out ($(stat -c %s "$out") bytes)"
