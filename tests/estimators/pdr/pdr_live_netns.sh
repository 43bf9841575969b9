#!/usr/bin/env bash
# ips-pdr end to end over real LCM multicast in a private network namespace: ips-sim
# (walk-square, seed 1, 174 s at 10x: at 20x, 2000 IMU datagrams a second, a loaded machine dropped
# one), ips-pdr (site from the SITE message) and the real
# lcm-logger as separate processes. On the recorded log: ips-pdr counted the in-process run's 278
# steps (the last STEP's index: a live run sees the same samples in the same order; 273 to 278
# only where ips-pdr's HEALTH reports messages lost on the way in), it published one POSE_PDR per
# step (its HEALTH's msgs_out: its SITE_REQUESTs, STEPs and poses), the logger recorded most of
# them (a loaded machine makes lcm-logger miss some: never more than published, at least 90 %),
# the last one within 5 m of the start (in-process closure: 3.46 m), and HEALTH from ips-pdr is
# there.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
lcm-logger -q -f "$WORK/live.lcm" & logger=$!; pids+=($logger)
# The logger is subscribed before ips-pdr starts: it records every SITE_REQUEST ips-pdr sends
# (its first comes at once), which the count of what ips-pdr published below takes out.
logger_sync "$WORK/live.lcm"
"$BIN/ips-pdr" --log-level warn & pdr=$!; pids+=($pdr)
"$BIN/ips-bus-check" --wait-for ips-pdr --timeout 60 || fail "ips-pdr did not come up"
logger_sync "$WORK/live.lcm"
"$BIN/ips-sim" --scenario walk-square --seed 1 --speed 10 --log-level warn
# Until ips-pdr has caught up: the walk's last step is at 163.6 s of the 174 (the one before at
# 163.1 s), so its pose is the one within 10.6 s of the end; or, if the bus lost IMU samples and
# with them that step, until ips-pdr is idle (HEALTH).
python3 "$ROOT/tests/integration/log_wait.py" "$WORK/live.lcm" --reach POSE_PDR \
  --end-after-site 174 --slack 10.6 --pid $pdr --or-idle ips-pdr
stop $pdr ips-pdr
stop $logger lcm-logger

"$BIN/ips-export" "$WORK/live.lcm" --out "$WORK/csv" --channels 'STEP|POSE_PDR' >/dev/null ||
  fail "ips-export failed"
# ips-pdr's own count is the last STEP's index (from 1); the rows are what lcm-logger recorded
# (the real tool: a message it misses under load is not ips-pdr's).
recorded=$(($(wc -l <"$WORK/csv/STEP.csv") - 1))
steps=$(python3 -c 'import csv, sys; print(max([int(r["index"]) for r in csv.DictReader(open(sys.argv[1]))] or [0]))' "$WORK/csv/STEP.csv")
poses=$(($(wc -l <"$WORK/csv/POSE_PDR.csv") - 1))
echo "STEP: ips-pdr counted $steps (the last index), lcm-logger recorded $recorded; POSE_PDR recorded $poses"
# What ips-pdr said it lost on the way in (its HEALTH: kernel, LCM queue, senders' sequence
# gaps). A loaded machine (the ASan build, 1000 IMU datagrams a second) can lose samples, and a
# lost sample can cost a step: then, and only then, a few steps fewer are right, said, not silent.
read -r lost published < <(python3 - "$WORK/live.lcm" "$ROOT/tests/integration" <<'PY'
import sys
sys.path.insert(0, sys.argv[2])
import lcm_log, lcm_messages
import struct
lost, last, imu, asked = 0, None, 0, 0
for c, _, d in lcm_log.events(sys.argv[1])[0]:
    imu += c == 'IMU'
    if c == 'SITE_REQUEST':  # site_t: fingerprint, utime, source (the asker), ...
        n = struct.unpack_from('>i', d, 16)[0]
        asked += d[20:20 + n - 1] == b'ips-pdr'
    if c == 'HEALTH':
        h = lcm_messages.health(d)
        if h['source'] == 'ips-pdr':
            lost = max(lost, h['kernel_drops'] + h['queue_drops'] + h['seq_lost'])
            last = h
if last:  # for a failure to be read: what ips-pdr took in against what the logger recorded
    print(f"ips-pdr's last HEALTH: msgs_in {last['msgs_in']}, kernel_drops {last['kernel_drops']}, "
          f"queue_drops {last['queue_drops']}, seq_lost {last['seq_lost']}; IMU in the log: {imu}",
          file=sys.stderr)
# What ips-pdr published besides HEALTH: its SITE_REQUESTs (before the simulator's traffic, when
# the logger misses nothing), then a STEP and a POSE_PDR per step.
print(lost, last['msgs_out'] - asked if last else -1)
PY
) || fail "cannot read ips-pdr's HEALTH from the log"
[ -n "$published" ] && [ "$published" -ge 0 ] || fail "no HEALTH from ips-pdr in the log"
if [ "$lost" -eq 0 ]; then
  [ "$steps" -eq 278 ] || fail "STEP: $steps steps (expected 278; ips-pdr reported no loss)"
else
  echo "ips-pdr reported $lost messages lost on the way in: $steps steps"
  [ "$steps" -le 278 ] && [ "$steps" -ge 273 ] ||
    fail "STEP: $steps steps (expected 273 to 278 with $lost messages lost)"
fi
# One pose per step, by ips-pdr's own count (msgs_out less its SITE_REQUESTs: STEPs and poses).
[ "$published" -eq $((2 * steps)) ] ||
  fail "ips-pdr published $published STEP and POSE_PDR messages (expected 2 x $steps: one pose per step)"
echo "ips-pdr published $published STEP and POSE_PDR messages: one pose per step"
# The logger may miss some of ips-pdr's messages on a loaded machine, never invent any.
[ "$recorded" -le "$steps" ] && [ $((10 * recorded)) -ge $((9 * steps)) ] ||
  fail "STEP: lcm-logger recorded $recorded of ips-pdr's $steps steps"
[ "$poses" -le "$steps" ] && [ $((10 * poses)) -ge $((9 * steps)) ] ||
  fail "POSE_PDR: lcm-logger recorded $poses poses of ips-pdr's $steps (one per step)"
python3 - "$WORK/csv/POSE_PDR.csv" <<'PY' || fail "POSE_PDR: the walk does not close"
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
last = rows[-1]
x, y = float(last['position_x_m']), float(last['position_y_m'])
gap = math.hypot(x, y)
print(f"POSE_PDR: {len(rows)} poses, last at ({x:.2f}, {y:.2f}): {gap:.2f} m from the start")
sys.exit(0 if gap < 5.0 else 1)
PY
grep -aq 'ips-pdr' "$WORK/live.lcm" || fail "no HEALTH message from ips-pdr in the log"
echo PASS
