#!/usr/bin/env bash
# --busy-poll-us and --lcm-receiver auto (core/node.cpp), over real LCM multicast in a private
# network namespace:
#  1. With liblcm's receiver it is refused at start: status 2 and one line saying that it needs
#     --lcm-receiver direct (liblcm's receive thread would sleep for every message anyway).
#  2. Two ips-fuse fuse the simulated lab (ips-sim live, the real lcm-logger recording): one with
#     --busy-poll-us 10000000 (it polls the bus without sleeping while messages come), one
#     without (its POSE_FUSED renamed POSE_FUSED_IDLE). Both publish poses. Over the same window
#     (until the sleeping one has fused 2 s more of the simulation, about 2 s of wall time) the
#     polling one takes at least 0.25 s of CPU and 3 times the other's
#     (which sleeps between messages): the option does what it says. Both stop on SIGINT with
#     status 0 (the polling loop still sees the signal).
#  3. ips-fuse's default receiver, auto: the sleeping one above (root, so granted the 4 MiB
#     buffer it asks for) says it reads the bus directly (log level debug); a third one, without CAP_NET_ADMIN and
#     asking for 1 GiB (above net.core.rmem_max, so capped), says it reads through liblcm's
#     receive thread and queues, and fuses all the same (its POSE_FUSED renamed
#     POSE_FUSED_LIBLCM).
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"

# 1. Refused with liblcm's receiver.
status=0
"$BIN/ips-fuse" --lcm-receiver liblcm --busy-poll-us 1000 --log-level warn >/dev/null \
  2>"$WORK/refused.err" || status=$?
[ "$status" -eq 2 ] || fail "--busy-poll-us with liblcm's receiver: status $status (expected 2)"
[ "$(wc -l <"$WORK/refused.err")" -eq 1 ] &&
  grep -q -- "--busy-poll-us needs --lcm-receiver direct" "$WORK/refused.err" ||
  fail "--busy-poll-us with liblcm's receiver said: $(cat "$WORK/refused.err")"
echo "ok: refused with liblcm's receiver: $(cat "$WORK/refused.err")"

# 2. Polling against sleeping, on the live lab.
lcm-logger -q -f "$WORK/run.lcm" & logger=$!; pids+=($logger)
logger_sync "$WORK/run.lcm"
"$BIN/ips-sim" --scenario lab --seed 1 --duration 120 --log-level warn & sim=$!; pids+=($sim)
"$BIN/ips-fuse" --busy-poll-us 10000000 --log-level warn & busy=$!; pids+=($busy)
"$BIN/ips-fuse" --channel POSE_FUSED=POSE_FUSED_IDLE --log-level debug 2>"$WORK/idle.err" &
idle=$!; pids+=($idle)
setpriv --bounding-set -net_admin "$BIN/ips-fuse" --channel POSE_FUSED=POSE_FUSED_LIBLCM \
  --lcm-url "${LCM_DEFAULT_URL%%\?*}?ttl=0&recv_buf_size=1073741824" --log-level info \
  2>"$WORK/capped.err" & capped=$!; pids+=($capped)
python3 - "$WORK/run.lcm" <<'PY' || fail "the three ips-fuse did not publish poses within 60 s"
import sys, time
from lcm_log import events
deadline = time.time() + 60
while time.time() < deadline:
    seen = {ch for ch, _, _ in events(sys.argv[1])[0]}
    if {'POSE_FUSED', 'POSE_FUSED_IDLE', 'POSE_FUSED_LIBLCM'} <= seen:
        sys.exit(0)
    time.sleep(0.2)
print(f'FAIL: poses seen on {sorted(c for c in seen if c.startswith("POSE_FUSED"))}')
sys.exit(1)
PY
cpu_s() {  # utime + stime of a process, seconds (fields 14 and 15 of /proc/PID/stat)
  awk -v hz="$(getconf CLK_TCK)" '{ sub(/^.*\) /, ""); print ($12 + $13) / hz }' "/proc/$1/stat"
}
b0=$(cpu_s $busy) i0=$(cpu_s $idle) t0=$(date +%s%N)
# The window: until the sleeping one has fused 2 s more of the simulation (its poses' utime).
python3 - "$WORK/run.lcm" <<'PY' || fail "no 2 s of poses on POSE_FUSED_IDLE within 60 s"
import struct, sys, time
from lcm_log import events
def newest():
    ts = [struct.unpack_from('>q', d, 8)[0] for ch, _, d in events(sys.argv[1])[0]
          if ch == 'POSE_FUSED_IDLE']
    return max(ts) if ts else 0
start, deadline = newest(), time.time() + 60
while newest() < start + 2_000_000:
    if time.time() > deadline:
        sys.exit(1)
    time.sleep(0.1)
PY
b1=$(cpu_s $busy) i1=$(cpu_s $idle) t1=$(date +%s%N)
python3 - "$b0" "$b1" "$i0" "$i1" "$t0" "$t1" <<'PY' || fail "--busy-poll-us did not poll"
import sys
b0, b1, i0, i1 = map(float, sys.argv[1:5])
wall = (int(sys.argv[6]) - int(sys.argv[5])) / 1e9
busy, idle = b1 - b0, i1 - i0
print(f'over {wall:.2f} s of wall time: ips-fuse --busy-poll-us 10000000 used {busy:.2f} s of CPU, '
      f'ips-fuse sleeping between messages {idle:.2f} s')
assert busy >= 0.25 and busy >= 3 * idle, (busy, idle)
PY
stop $busy "ips-fuse --busy-poll-us"
stop $idle "ips-fuse"
stop $capped "ips-fuse (capped buffer)"
grep -q -- "--lcm-receiver auto: reading the bus directly" "$WORK/idle.err" ||
  fail "ips-fuse with its buffer granted did not read directly: $(head -5 "$WORK/idle.err")"
grep -q -- "--lcm-receiver auto: reading the bus through liblcm's receive thread" \
  "$WORK/capped.err" ||
  fail "ips-fuse with a capped buffer did not say it reads through liblcm: $(head -5 "$WORK/capped.err")"
echo "ok: --lcm-receiver auto: $(grep -o 'reading the bus directly.*' "$WORK/idle.err"); capped: \
$(grep -o 'reading the bus through.*' "$WORK/capped.err")"
echo "PASS"
