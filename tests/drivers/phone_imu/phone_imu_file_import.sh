#!/usr/bin/env bash
# ips-phone-imu --file: a recorded file in the source app's form (semicolon-separated, ms times,
# a header mapped by name;
# ../shared/reference/002_pdr.md section 1; columns t,ax..az,gx..gz,mx..mz, a sensor's fields empty
# in rows where it has no reading) imported
#  1. into an LCM log (--out): exactly the expected IMU messages (utime = the epoch ms time,
#     device_utime the same, gyroscope/magnetometer carried from within 50 ms, else NaN), the
#     header mapped, bad rows counted with the first reason, a repeated time dropped;
#     --file-start-s places a file of time-since-boot rows at a given Unix time;
#  2. onto the bus (real LCM multicast in a private namespace, lcm-logger recording) with
#     --as-fast-as-possible: the same messages, and HEALTH counts the bad lines.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

cat >"$WORK/walk.txt" <<'TXT'
time;ax;ay;az;gx;gy;gz;mx;my;mz
1682424000000;0.1;-0.2;9.81;0.01;0.02;0.03;20;-3;-40
1682424000003;0.2;-0.1;9.8;0.02;;;;;
1682424000005;0.3;0;9.79;;;;;;
garbage
1682424000100;0.4;0;9.7;0.5;0.5;0.5;;;
1682424000100;0.4;0;9.7;;;;;;
TXT
sed -e '1d' -e 's/^1682424000/7/' "$WORK/walk.txt" >"$WORK/boot.txt"  # since boot: 7000 ms..

"$BIN/ips-phone-imu" --file "$WORK/walk.txt" --out "$WORK/out.lcm" 2>"$WORK/out.err" ||
  fail "--out: status $?: $(cat "$WORK/out.err")"
grep -qF "6 rows read, 3 messages written to $WORK/out.lcm, 2 rows rejected (first: line 3 '1682424000003;0.2;-0.1;9.8;0.02;;;;;': gyroscope y '' is not a number), 1 readings dropped" "$WORK/out.err" &&
  grep -qF "walk.txt: semicolon-separated (detected), columns t,ax,ay,az,gx,gy,gz,mx,my,mz (from the header), times in ms (guessed from the first time's magnitude)" "$WORK/out.err" ||
  fail "--out: the summary: $(cat "$WORK/out.err")"
# The deprecated spellings still work (--file-time-unit, --file-start-s).
"$BIN/ips-phone-imu" --file "$WORK/boot.txt" --file-start-s 1700000000.5 --file-time-unit ms \
  --device-id mi9 --out "$WORK/boot.lcm" 2>/dev/null || fail "--file-start-s"

python3 - "$WORK" <<'PY' || fail "--out: the log"
import math, sys
from lcm_log import events
from lcm_messages import _Reader
work = sys.argv[1]
nan = float('nan')
def imu(data):
    r = _Reader(data)
    return (r.take('q'), r.string(), r.string(), r.take('q'), [r.take('d') for _ in range(3)],
            [r.take('d') for _ in range(3)], [r.take('d') for _ in range(3)])
def same(a, b):
    return all((math.isnan(x) and math.isnan(y)) or x == y for x, y in zip(a, b))
t0 = 1682424000000000
want = [(t0, 'ips-phone-imu:file', 'phone', t0, [0.1, -0.2, 9.81], [0.01, 0.02, 0.03], [20, -3, -40]),
        (t0 + 5000, 'ips-phone-imu:file', 'phone', t0 + 5000, [0.3, 0, 9.79], [0.01, 0.02, 0.03], [20, -3, -40]),
        (t0 + 100000, 'ips-phone-imu:file', 'phone', t0 + 100000, [0.4, 0, 9.7], [0.5, 0.5, 0.5], [nan] * 3)]
log, read, size = events(f'{work}/out.lcm')
assert read == size and [ch for ch, _, _ in log] == ['IMU'] * 3, log
got = [imu(d) for _, _, d in log]
for g, w in zip(got, want):
    assert g[:4] == w[:4] and all(same(a, b) for a, b in zip(g[4:], w[4:])), f'\n got  {g}\n want {w}'
assert [ts for _, ts, _ in log] == [w[0] for w in want]
boot = [imu(d) for _, _, d in events(f'{work}/boot.lcm')[0]]
# First row (7000 ms since boot) at 1700000000.5 s; device_utime stays the phone's time.
assert [(m[0], m[2], m[3]) for m in boot] == [(1700000000500000, 'mi9', 7000000),
                                             (1700000000505000, 'mi9', 7005000),
                                             (1700000000600000, 'mi9', 7100000)], boot
print('ok: --out: 3 messages exactly; --file-start-s maps time since boot')
PY

lcm-logger -q -f "$WORK/live.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
logger_sync "$WORK/live.lcm"
"$BIN/ips-phone-imu" --file "$WORK/walk.txt" --as-fast-as-possible 2>"$WORK/live.err" ||
  fail "--as-fast-as-possible: status $?: $(cat "$WORK/live.err")"
logger_sync "$WORK/live.lcm"
stop $logger lcm-logger
python3 - "$WORK" <<'PY' || fail "onto the bus"
import sys
from lcm_log import events
from lcm_messages import health
work = sys.argv[1]
out = [d for ch, _, d in events(f'{work}/out.lcm')[0]]
live = events(f'{work}/live.lcm')[0]
assert [d for ch, _, d in live if ch == 'IMU'] == out, 'the bus did not carry the --out messages'
hb = [health(d) for ch, _, d in live if ch == 'HEALTH' and health(d)['source'] == 'ips-phone-imu']
last = hb[-1]
assert (last['msgs_in'], last['msgs_out'], last['parse_errors'], last['drops']) == (7, 3, 2, 1), last
print('ok: on the bus: the same 3 messages; HEALTH msgs_in 7, parse_errors 2, drops 1')
PY
