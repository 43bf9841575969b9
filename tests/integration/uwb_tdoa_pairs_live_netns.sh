#!/usr/bin/env bash
# ips-uwb-tdoa on pairwise TDoA over real LCM multicast in a private network namespace: ips-sim
# (loco-tdoa: UWB_TDOA pairs only, anchor L3 1 m short; seed 1, 60 s at 10x), ips-uwb-tdoa (site
# from the SITE message) and the real lcm-logger as separate processes. Then, on the recorded log,
# ips-eval: POSE_TDOA horizontal RMSE <= 0.15 m (the replay measures 0.043 m) over at least 500
# estimates; HEALTH from ips-uwb-tdoa is in the log. Exit 77 (skipped) without a namespace.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

SPEED=10

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"

lcm-logger -q -f "$WORK/live.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-uwb-tdoa" --log-level warn & tdoa=$!; pids+=($tdoa)
"$BIN/ips-bus-check" --wait-for ips-uwb-tdoa --timeout 60 || fail "ips-uwb-tdoa did not come up"
logger_sync "$WORK/live.lcm"
"$BIN/ips-sim" --scenario loco-tdoa --seed 1 --speed $SPEED --log-level warn
python3 "$HERE/log_wait.py" "$WORK/live.lcm" --reach POSE_TDOA --end-after-site 60 \
  --pid $tdoa --or-idle ips-uwb-tdoa
stop $tdoa ips-uwb-tdoa
stop $logger lcm-logger

json=$("$BIN/ips-eval" --json "$WORK/live.lcm")
echo "$json"
row=$(echo "$json" | tr '{' '\n' | grep '"channel": "POSE_TDOA"' || true)
[ -n "$row" ] || fail "no POSE_TDOA row in ips-eval output"
count=$(echo "$row" | sed -E 's/.*"count": ([0-9]+).*/\1/')
rmse=$(echo "$row" | sed -E 's/.*"rmse_h": ([0-9.]+|null).*/\1/')
[ "$count" -ge 500 ] || fail "POSE_TDOA: only $count estimates scored (expected about 590)"
awk -v r="$rmse" 'BEGIN { exit !(r <= 0.15) }' || fail "POSE_TDOA: rmse_h $rmse (bound 0.15)"
echo "POSE_TDOA from UWB_TDOA pairs: count $count rmse_h $rmse (bound 0.15): ok"
grep -aq 'ips-uwb-tdoa' "$WORK/live.lcm" || fail "no HEALTH message from ips-uwb-tdoa in the log"
echo "PASS"
