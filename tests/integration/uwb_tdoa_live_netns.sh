#!/usr/bin/env bash
# ips-uwb-tdoa end to end over real LCM multicast in a private network namespace: ips-sim
# (tdoa-hall, seed 1, 120 s at 10x), ips-uwb-tdoa (site from the SITE message) and the real
# lcm-logger run as separate processes. Then, on the recorded log:
#  - ips-eval: POSE_TDOA horizontal RMSE <= 0.20 m (the in-process tests measure 0.064 m) over at
#    least 1000 estimates (10 Hz from about 4 s);
#  - ips-export: CLOCK has estimates for all six anchors relative to master A4, each anchor's last
#    one tracking (status 0) after at least 50 syncs, with rates within the scenario's +-45 ppb
#    spread;
#  - HEALTH from ips-uwb-tdoa is in the log.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

SPEED=10

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"

lcm-logger -q -f "$WORK/live.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-uwb-tdoa" --log-level warn & tdoa=$!; pids+=($tdoa)
# Publish only once the tracker is up (it reports on HEALTH as it starts) and the logger has
# subscribed.
"$BIN/ips-bus-check" --wait-for ips-uwb-tdoa --timeout 60 || fail "ips-uwb-tdoa did not come up"
logger_sync "$WORK/live.lcm"
start=$(date +%s.%N)
"$BIN/ips-sim" --scenario tdoa-hall --seed 1 --speed $SPEED --log-level warn
echo "ips-sim: 120 s of tdoa-hall at x$SPEED took $(awk -v s="$start" -v e="$(date +%s.%N)" 'BEGIN{printf "%.1f", e-s}') s"
# Until ips-uwb-tdoa has caught up with the 120 s the simulator published.
python3 "$HERE/log_wait.py" "$WORK/live.lcm" --reach POSE_TDOA --end-after-site 120 \
  --pid $tdoa --or-idle ips-uwb-tdoa
stop $tdoa ips-uwb-tdoa
stop $logger lcm-logger

# --- positions -------------------------------------------------------------------------------
json=$("$BIN/ips-eval" --json "$WORK/live.lcm")
echo "$json"
row=$(echo "$json" | tr '{' '\n' | grep '"channel": "POSE_TDOA"' || true)
[ -n "$row" ] || fail "no POSE_TDOA row in ips-eval output"
count=$(echo "$row" | sed -E 's/.*"count": ([0-9]+).*/\1/')
rmse=$(echo "$row" | sed -E 's/.*"rmse_h": ([0-9.]+|null).*/\1/')
p95=$(echo "$row" | sed -E 's/.*"p95_h": ([0-9.]+|null).*/\1/')
[ "$count" -ge 1000 ] || fail "POSE_TDOA: only $count estimates scored (expected about 1160)"
awk -v r="$rmse" 'BEGIN { exit !(r <= 0.20) }' || fail "POSE_TDOA: rmse_h $rmse (bound 0.20)"
echo "POSE_TDOA: count $count rmse_h $rmse p95_h $p95 (bound 0.20): ok"

# --- clocks ----------------------------------------------------------------------------------
"$BIN/ips-export" "$WORK/live.lcm" --out "$WORK/csv" --channels 'CLOCK' --format csv >/dev/null ||
  fail "ips-export failed"
[ -s "$WORK/csv/CLOCK.csv" ] || fail "no CLOCK messages in the log"
head -1 "$WORK/csv/CLOCK.csv" | grep -q '^utime_us,source,anchor_id,master_id,offset_s,offset_std_s,rate_ppb,rate_std_ppb,num_syncs,status$' ||
  fail "unexpected CLOCK.csv header: $(head -1 "$WORK/csv/CLOCK.csv")"
# Per anchor: the last row (the log is in time order) must be tracking, relative to A4.
awk -F, 'NR > 1 { last[$3] = $0; n[$3]++ }
  END {
    bad = 0; anchors = 0
    for (a in last) {
      anchors++
      split(last[a], f, ",")
      printf "CLOCK %s: %d messages, last: master %s offset %s s rate %s ppb (std %s) syncs %s status %s\n",
             a, n[a], f[4], f[5], f[7], f[8], f[9], f[10]
      if (f[2] != "uwb_tdoa" || f[4] != "A4" || f[10] != 0 || f[9] < 50 || f[7] < -91 || f[7] > 91) bad = 1
    }
    if (anchors != 6) { print "expected 6 anchors, got " anchors; bad = 1 }
    exit bad
  }' "$WORK/csv/CLOCK.csv" || fail "CLOCK estimates not as expected"

grep -aq 'ips-uwb-tdoa' "$WORK/live.lcm" || fail "no HEALTH message from ips-uwb-tdoa in the log"
echo "PASS"
