#!/usr/bin/env bash
# ips-fuse end to end over real LCM multicast in a private network namespace: ips-sim
# (corridor-L-2: UWB ranges from 2 anchors and the foot-INS module, seed 1, 40 s at 10x), ips-fuse
# (site from the SITE message) and the real lcm-logger as separate processes. On the recorded log:
#  - ips-eval scores POSE_FUSED: horizontal RMSE <= 0.378 m (the issue's bound for 2 anchors; the
#    in-process test measures 0.22 m for this seed) over at least 150 poses (one per range or INS
#    position when 0.1 s have passed: 161 in-process);
#  - POSE_FUSED's source names the ranges and the INS module; HEALTH from ips-fuse is there;
#  - ips-fuse-latency (the latency benchmark's tool, scripts/bench-fuse-latency) against ips-fuse
#    for 2 s with 3 tags: every range's pose arrives, the percentiles are printed;
#  - --help exits 0; a bad --site and an unknown flag are one line each and status 2.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
source "$ROOT/tests/integration/cli_test_lib.sh"

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
lcm-logger -q -f "$WORK/fuse.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-fuse" --log-level warn & fuse=$!; pids+=($fuse)
"$BIN/ips-bus-check" --wait-for ips-fuse --timeout 60 || fail "ips-fuse did not come up"
logger_sync "$WORK/fuse.lcm"
"$BIN/ips-sim" --scenario corridor-L-2 --seed 1 --speed 10 --log-level warn
# Until ips-fuse has caught up with the 40 s the simulator published.
python3 "$ROOT/tests/integration/log_wait.py" "$WORK/fuse.lcm" --reach POSE_FUSED \
  --end-after-site 40 --pid $fuse --or-idle ips-fuse
stop $fuse ips-fuse
stop $logger lcm-logger

json=$("$BIN/ips-eval" --json "$WORK/fuse.lcm")
row=$(echo "$json" | tr '{' '\n' | grep '"channel": "POSE_FUSED"' || true)
[ -n "$row" ] || fail "no POSE_FUSED row in ips-eval output: $json"
count=$(echo "$row" | sed -E 's/.*"count": ([0-9]+).*/\1/')
rmse=$(echo "$row" | sed -E 's/.*"rmse_h": ([0-9.]+|null).*/\1/')
[ "$count" -ge 150 ] || fail "POSE_FUSED: only $count poses scored (expected about 161)"
awk -v r="$rmse" 'BEGIN { exit !(r <= 0.378) }' || fail "POSE_FUSED: rmse_h $rmse (bound 0.378)"
echo "live ips-fuse: POSE_FUSED count $count rmse_h $rmse (bound 0.378): ok"
python3 - "$WORK/fuse.lcm" <<'PY' || fail "POSE_FUSED sources or HEALTH"
import struct, sys
from lcm_log import events
from lcm_messages import health
ev = events(sys.argv[1])[0]
def source(data):  # pose_t: fingerprint, utime, then the source string
    n = struct.unpack_from('>i', data, 16)[0]
    return data[20:20 + n - 1].decode()
sources = {source(d) for ch, _, d in ev if ch == 'POSE_FUSED'}
assert 'fuse:uwb_range+ins_module' in sources, sources
mine = [health(d) for ch, _, d in ev if ch == 'HEALTH' and health(d)['source'] == 'ips-fuse']
assert mine and mine[-1]["msgs_in"] > 200, mine[-1:]
print('sources:', sorted(sources), '; HEALTH msgs_in', mine[-1]['msgs_in'])
PY

"$BIN/ips-fuse-latency" --print-site --tags 3 > "$WORK/latency.yaml"
"$BIN/ips-fuse" --site "$WORK/latency.yaml" --log-level warn & fuse=$!; pids+=($fuse)
"$BIN/ips-bus-check" --wait-for ips-fuse --timeout 60 > /dev/null || fail "ips-fuse did not come up"
# --drain 30: the poses still due after the 2 s are waited for (a loaded machine can be late by
# more than the default half second), at most 30 s; it ends as soon as none is missing.
out=$("$BIN/ips-fuse-latency" --tags 3 --seconds 2 --warmup 1 --drain 30 --cpu-pid $fuse) ||
  fail "ips-fuse-latency: $out"
stop $fuse ips-fuse
echo "$out"
# 3 tags x 8 anchors x 10 Hz x 2 s; a loaded machine may drop a datagram or two.
echo "$out" | grep -qE "^ranges published 4[0-9]{2}, poses matched 4[0-9]{2}, missing [0-4]$" ||
  fail "ips-fuse-latency: poses missing"
echo "$out" | grep -qE "^latency us: p50 [0-9]+ p90 [0-9]+ p99 [0-9]+" || fail "no percentiles"

"$BIN/ips-fuse" --help | grep -q "POSE_FUSED" || fail "--help does not describe the program"
printf 'name: bad\nanchors: []\ntags: [{id: T1}]\nestimators:\n  fuse: {displacement: teleport}\n' \
  >"$WORK/bad.yaml"
expect_error "^ips-fuse: error: .*bad.yaml:5: estimators.fuse.displacement: expected auto, ins_module" \
  "$BIN/ips-fuse" --site "$WORK/bad.yaml"
expect_error "^ips-fuse: error: " "$BIN/ips-fuse" --no-such-flag
echo "PASS"
