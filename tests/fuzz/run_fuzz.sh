#!/usr/bin/env bash
# run_fuzz.sh FUZZER SEED_DIR SECONDS: runs a libFuzzer target for a bounded time on a scratch
# corpus seeded from SEED_DIR (the source tree is never written). Fails on any finding.
set -euo pipefail
fuzzer=$1 seeds=$2 seconds=$3
corpus=$(mktemp -d)
artifacts=$(mktemp -d)
trap 'rm -rf "$corpus"' EXIT
"$fuzzer" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
  -artifact_prefix="$artifacts/" "$corpus" "$seeds" 2>&1 | tail -15
status=${PIPESTATUS[0]}
if [ "$status" -ne 0 ]; then
  echo "fuzz finding kept in $artifacts:"; ls -la "$artifacts"
  exit "$status"
fi
rm -rf "$artifacts"
