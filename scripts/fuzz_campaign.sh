#!/usr/bin/env bash
# The fuzz campaign (make fuzz-campaign): every libFuzzer target of tests/fuzz/ runs FUZZ_RUNS executions
# (default 10^7) from its checked-in corpus. Afterwards the inputs that found new coverage are merged into
# tests/fuzz/corpus/<name>/ (libFuzzer -merge=1: only inputs adding features, so the corpus stays minimal) and
# every crash, leak or timeout is copied there as crash-<sha1>, so `make test` replays it from then on.
# Environment: BUILD_DIR (build-fuzz), FUZZ_RUNS (10000000), FUZZ_TARGETS (all: "pqr_reader gzip_body ..."),
# FUZZ_TIMEOUT (seconds per input, 10), FUZZ_MAX_TIME (seconds per target, 0 = no limit), FUZZ_MERGE (1).
# Writes $BUILD_DIR/campaign/summary.md (target, executions, seconds, exec/s, new corpus files, crashes).
# Exit status: 1 when any target crashed.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build-fuzz}
FUZZ_RUNS=${FUZZ_RUNS:-10000000}
FUZZ_TIMEOUT=${FUZZ_TIMEOUT:-10}
FUZZ_MAX_TIME=${FUZZ_MAX_TIME:-0}
FUZZ_MERGE=${FUZZ_MERGE:-1}
if [[ -z "${FUZZ_TARGETS:-}" ]]; then
  FUZZ_TARGETS=$(for f in tests/fuzz/*_fuzzer.cpp; do basename "$f" _fuzzer.cpp; done | tr '\n' ' ')
fi
campaign="$BUILD_DIR/campaign"
mkdir -p "$campaign"
summary="$campaign/summary.md"
{
  echo "| target | executions | seconds | exec/s | corpus before | merged in | crashes |"
  echo "|---|---:|---:|---:|---:|---:|---:|"
} > "$summary"
failed=0
for name in $FUZZ_TARGETS; do
  fuzzer="$BUILD_DIR/bin/${name}_fuzzer"
  corpus="tests/fuzz/corpus/$name"
  work="$campaign/$name"
  [[ -x "$fuzzer" ]] || { echo "fuzz-campaign: $fuzzer is missing (make fuzz-campaign builds it)" >&2; exit 2; }
  rm -rf "$work" && mkdir -p "$work/new" "$work/artifacts" "$corpus"
  before=$(find "$corpus" -type f | wc -l)
  echo "== $name: $FUZZ_RUNS runs from $before corpus files"
  start=$(date +%s)
  status=0
  # New inputs go to the first directory only; the checked-in corpus is read, never written, by this run.
  "$fuzzer" -runs="$FUZZ_RUNS" -max_total_time="$FUZZ_MAX_TIME" -timeout="$FUZZ_TIMEOUT" -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$work/artifacts/" "$work/new" "$corpus" > "$work/log" 2>&1 || status=$?
  seconds=$(( $(date +%s) - start ))
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log" | tail -1)
  runs=${runs:-0}
  crashes=0
  for artifact in "$work"/artifacts/*; do
    [[ -f "$artifact" ]] || continue
    sha=$(sha1sum "$artifact" | cut -c1-16)
    kind=$(basename "$artifact" | cut -d- -f1)
    cp "$artifact" "$corpus/regression-$kind-$sha"
    echo "   $kind: $artifact → $corpus/regression-$kind-$sha" >&2
    crashes=$((crashes + 1))
  done
  if (( status != 0 )); then
    failed=1
    (( crashes > 0 )) || echo "   $name exited with $status without an artifact (see $work/log)" >&2
  fi
  merged=0
  if [[ "$FUZZ_MERGE" == 1 ]] && compgen -G "$work/new/*" > /dev/null; then
    "$fuzzer" -merge=1 -timeout="$FUZZ_TIMEOUT" -rss_limit_mb=2048 -artifact_prefix="$work/merge-" "$corpus" "$work/new" > "$work/merge.log" 2>&1 || true
    merged=$(( $(find "$corpus" -type f | wc -l) - before - crashes ))
  fi
  rate=$(( runs / (seconds > 0 ? seconds : 1) ))
  echo "| $name | $runs | $seconds | $rate | $before | $merged | $crashes |" >> "$summary"
  echo "   $runs runs in ${seconds}s, $merged inputs merged into $corpus, $crashes crash(es)"
done
echo
cat "$summary"
exit $failed
