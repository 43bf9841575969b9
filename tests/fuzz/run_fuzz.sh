#!/usr/bin/env bash
# run_fuzz.sh FUZZER SEED_DIR SECONDS [INPUT_DIR...]: runs a libFuzzer target for a bounded time on
# a scratch corpus, reading SEED_DIR and every further INPUT_DIR that exists (e.g. the kept corpus
# tests/fuzz/corpus/<name>) as read-only inputs: libFuzzer writes only to its first directory, the
# scratch one, so the source tree is never written. Fails on any finding.
set -uo pipefail
fuzzer=$1 seeds=$2 seconds=$3
shift 3
inputs=("$seeds")
for dir in "$@"; do
  [ -d "$dir" ] && inputs+=("$dir")
done
corpus=$(mktemp -d)
artifacts=$(mktemp -d)
trap 'rm -rf "$corpus"' EXIT
"$fuzzer" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
  -artifact_prefix="$artifacts/" "$corpus" "${inputs[@]}" >"$artifacts/fuzz.log" 2>&1
status=$?
if [ "$status" -ne 0 ]; then
  # The cause first (a CI log keeps only the end of the output), then the input that found it.
  grep -m 6 -E 'ERROR:|what\(\):|runtime error:|SUMMARY:' "$artifacts/fuzz.log" || true
  tail -15 "$artifacts/fuzz.log"
  for f in "$artifacts"/crash-* "$artifacts"/leak-* "$artifacts"/timeout-* "$artifacts"/oom-*; do
    [ -f "$f" ] || continue
    echo "finding $f ($(stat -c %s "$f") bytes), first 256 bytes:"
    head -c 256 "$f" | od -A d -c | head -20
  done
  echo "fuzz finding kept in $artifacts"
  exit "$status"
fi
tail -15 "$artifacts/fuzz.log"
rm -rf "$artifacts"
