#!/usr/bin/env bash
# The fuzz campaign (make fuzz-campaign): every libFuzzer target of tests/fuzz/ runs FUZZ_RUNS executions
# (default 10^7) from its checked-in corpus. Afterwards the inputs that found new coverage are merged into
# tests/fuzz/corpus/<name>/ (libFuzzer -merge=1: only inputs adding features, so the corpus stays minimal) and
# every crash, leak or timeout is copied there as regression-<kind>-<sha1>, so `make test` replays it from then on.
# Environment: BUILD_DIR (build-fuzz), FUZZ_RUNS (10000000), FUZZ_TARGETS (all: "pqr_reader gzip_body ..."),
# FUZZ_TIMEOUT (seconds per input, 10), FUZZ_MAX_TIME (seconds per target, 0 = no limit), FUZZ_MERGE (1),
# FUZZ_JOBS (targets fuzzed at once, 1; one libFuzzer process each, so at most one per core).
# On a shared machine run it as `nice -n 19 make fuzz-campaign`: the fuzzers then take idle CPU only.
# Writes $BUILD_DIR/campaign/summary.md (target, executions, seconds, exec/s, corpus files before and after, inputs
# merged in, crashes), its rows in FUZZ_TARGETS order. Exit status: 1 when any target crashed.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build-fuzz}
FUZZ_RUNS=${FUZZ_RUNS:-10000000}
FUZZ_TIMEOUT=${FUZZ_TIMEOUT:-10}
FUZZ_MAX_TIME=${FUZZ_MAX_TIME:-0}
FUZZ_MERGE=${FUZZ_MERGE:-1}
FUZZ_JOBS=${FUZZ_JOBS:-1}
if [[ -z "${FUZZ_TARGETS:-}" ]]; then
  FUZZ_TARGETS=$(for f in tests/fuzz/*_fuzzer.cpp; do basename "$f" _fuzzer.cpp; done | tr '\n' ' ')
fi
campaign="$BUILD_DIR/campaign"
mkdir -p "$campaign"
for name in $FUZZ_TARGETS; do
  [[ -x "$BUILD_DIR/bin/${name}_fuzzer" ]] || {
    echo "fuzz-campaign: $BUILD_DIR/bin/${name}_fuzzer is missing (make fuzz-campaign builds it)" >&2
    exit 2
  }
done

# One target: fuzz, keep the crashes, merge the new coverage; writes $work/row (a summary row) and $work/failed.
fuzz_target() {
  local name=$1
  local fuzzer="$BUILD_DIR/bin/${name}_fuzzer" corpus="tests/fuzz/corpus/$name" work="$campaign/$name"
  rm -rf "$work" && mkdir -p "$work/new" "$work/artifacts" "$corpus"
  local before
  before=$(find "$corpus" -type f | wc -l)
  echo "== $name: $FUZZ_RUNS runs from $before corpus files"
  local start status=0
  start=$(date +%s)
  # New inputs go to the first directory only; the checked-in corpus is read, never written, by this run.
  "$fuzzer" -runs="$FUZZ_RUNS" -max_total_time="$FUZZ_MAX_TIME" -timeout="$FUZZ_TIMEOUT" -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$work/artifacts/" "$work/new" "$corpus" > "$work/log" 2>&1 || status=$?
  local seconds runs
  seconds=$(( $(date +%s) - start ))
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log" | tail -1)
  runs=${runs:-0}
  local crashes=0 artifact sha kind
  for artifact in "$work"/artifacts/*; do
    [[ -f "$artifact" ]] || continue
    sha=$(sha1sum "$artifact" | cut -c1-16)
    kind=$(basename "$artifact" | cut -d- -f1)
    cp "$artifact" "$corpus/regression-$kind-$sha"
    echo "   $name $kind: $artifact → $corpus/regression-$kind-$sha" >&2
    crashes=$((crashes + 1))
  done
  if (( status != 0 )); then
    echo failed > "$work/failed"
    (( crashes > 0 )) || echo "   $name exited with $status without an artifact (see $work/log)" >&2
  fi
  local merged=0
  if [[ "$FUZZ_MERGE" == 1 ]] && compgen -G "$work/new/*" > /dev/null; then
    "$fuzzer" -merge=1 -timeout="$FUZZ_TIMEOUT" -rss_limit_mb=2048 -artifact_prefix="$work/merge-" "$corpus" "$work/new" > "$work/merge.log" 2>&1 || true
    merged=$(( $(find "$corpus" -type f | wc -l) - before - crashes ))
  fi
  local after rate
  after=$(find "$corpus" -type f | wc -l)
  rate=$(( runs / (seconds > 0 ? seconds : 1) ))
  echo "| $name | $runs | $seconds | $rate | $before | $after | $merged | $crashes |" > "$work/row"
  echo "   $name: $runs runs in ${seconds}s, $merged inputs merged into $corpus, $crashes crash(es)"
}

running=0
for name in $FUZZ_TARGETS; do
  if (( running >= FUZZ_JOBS )); then
    wait -n || true
    running=$((running - 1))
  fi
  fuzz_target "$name" &
  running=$((running + 1))
done
wait || true

summary="$campaign/summary.md"
failed=0
{
  echo "| target | executions | seconds | exec/s | corpus before | corpus after | merged in | crashes |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|"
  for name in $FUZZ_TARGETS; do
    cat "$campaign/$name/row" 2>/dev/null || echo "| $name | (no result: see $campaign/$name/log) | | | | | | |"
  done
} > "$summary"
for name in $FUZZ_TARGETS; do
  if [[ -f "$campaign/$name/failed" || ! -f "$campaign/$name/row" ]]; then failed=1; fi
done
echo
cat "$summary"
exit $failed
