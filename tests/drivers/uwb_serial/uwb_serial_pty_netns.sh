#!/usr/bin/env bash
# ips-uwb-serial end to end: the real program on pseudo-terminals (a fake tag on the master side,
# fake_uwb_device.py), real LCM multicast in a private network namespace, the real lcm-logger
# recording, ips-export reading the log back.
#  1. Listen mode, --format auto: started before the device exists (retries, HEALTH says so);
#     PANS lec lines and RANGE lines become exactly the expected UWB_RANGE and POSE_UWB_MODULE
#     messages (values, ids, seq, NaN, source, reception time); garbled, overlong and no-fix lines
#     are counted in HEALTH (parse_errors 3, drops 1); unplug (master closed, link removed) is in
#     HEALTH as degraded + "device ... gone; retrying"; after replug the new lines are published
#     and a line cut by the unplug is not; SIGINT ends it with status 0.
#  2. --pans-shell: the tag receives "\r\r", then "lec\r", and at SIGINT "lec\r" and "quit\r";
#     its lec lines are published; its banner is not counted as parse errors.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
FAKE="$HERE/fake_uwb_device.py"
wait_file() {  # path seconds
  local i
  for ((i = 0; i < $2 * 20; i++)); do [ -e "$1" ] && return 0; sleep 0.05; done
  fail "timed out waiting for $1"
}

lcm-logger -q -f "$WORK/listen.lcm" & logger=$!; pids+=($logger)
# The logger starts first: subscribed by the time of logger_sync (whose first probe is then kept).
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"

# --- 1: listen mode, missing at start, unplug and replug -------------------------------------
logger_sync "$WORK/listen.lcm"
# published LOG CHANNEL N: until LOG holds N messages on CHANNEL (at most 60 s). The position
# of a line is published with its ranges, by one handler: once it is there, they are too.
published() {
  python3 "$HERE/../health_wait.py" "$1" --channel "$2" --count "$3" || fail "$2 not published"
}
DEV="$WORK/ttyUWB"
"$BIN/ips-uwb-serial" --device "$DEV" --format auto --tag 1A2B --reopen-s 0.2 \
  2>"$WORK/listen.err" & drv=$!; pids+=($drv)
python3 "$FAKE" listen "$DEV" "$WORK/listen.err" "$WORK" & fake=$!; pids+=($fake)
wait_file "$WORK/listen.done" 120
published "$WORK/listen.lcm" POSE_UWB_MODULE 2
stop $drv ips-uwb-serial
touch "$WORK/stop"
wait $fake || fail "the fake device failed"
forget $fake
logger_sync "$WORK/listen.lcm"
stop $logger lcm-logger
grep -q "not available (No such file or directory); retrying every 0.2 s" "$WORK/listen.err" ||
  fail "no clear log line for the missing device: $(cat "$WORK/listen.err")"
"$BIN/ips-export" "$WORK/listen.lcm" --out "$WORK/listen-csv" >/dev/null || fail "ips-export"
python3 - "$WORK/listen-csv" "$WORK/sent.json" "$DEV" <<'PY' || fail "listen mode: published messages"
import csv, json, math, sys
d, sent_path, dev = sys.argv[1], sys.argv[2], sys.argv[3]
rows = lambda ch: list(csv.DictReader(open(f'{d}/{ch}.csv')))
ranges = rows('UWB_RANGE')
src = 'ips-uwb-serial:' + dev
guide = [('1151', 6.44), ('0CA8', 6.50), ('111C', 3.24), ('1150', 3.19)]
want = ([('1A2B', a, r, None, 0) for a, r in guide] +
        [('1A2B', '2F2F', 2.21, None, 0), ('1A2B', '2C9D', 2.39, None, 0),
         ('T7', 'A3', 4.25, -78.5, 0), ('T7', 'A4', 5.5, None, 0),
         ('T7', 'A3', 4.30, -79.0, 1)] +
        [('1A2B', a, r, None, 1) for a, r in guide])
got = [(r['tag_id'], r['anchor_id'], float(r['range_m']),
        None if math.isnan(float(r['rx_power_dbm'])) else float(r['rx_power_dbm']),
        int(r['seq'])) for r in ranges]
assert got == want, f'UWB_RANGE:\n got  {got}\n want {want}'
for r in ranges:
    assert r['source'] == src, r['source']
    assert math.isnan(float(r['fp_power_dbm'])) and math.isnan(float(r['quality'])), r
# Reception time: after the write, within 2 s (the host's clock on reception: a loaded machine can
# be a fraction of a second late to read); the ranges of one lec line share it.
sent = json.load(open(sent_path))
t_guide = next(s['t_us'] for s in sent if s['text'].startswith('DIST,4'))
utimes = [int(r['utime_us']) for r in ranges]
assert len(set(utimes[:4])) == 1, utimes[:4]
assert t_guide <= utimes[0] <= t_guide + 2000000, (t_guide, utimes[0])
poses = rows('POSE_UWB_MODULE')
assert len(poses) == 2, poses
for p in poses:
    assert p['tag_id'] == '1A2B' and p['source'] == src, p
    assert [float(p[k]) for k in ('position_x_m', 'position_y_m', 'position_z_m')] == [2.55, 2.01, 1.71], p
    assert int(p['num_used']) == 4 and int(p['status']) == 1, p
    assert all(math.isnan(float(p[k])) for k in p if k.startswith(('position_cov', 'velocity'))), p
assert int(poses[0]['utime_us']) == utimes[0], 'pose and ranges of one line have one time'
health = [h for h in rows('HEALTH') if h['source'] == 'ips-uwb-serial']
missing = [h for h in health if 'not available (No such file or directory)' in h['last_error']]
assert missing and all(h['state'] == '1' for h in missing), 'HEALTH never said the device was missing'
gone = [h for h in health if h['last_error'] == f'device {dev} gone; retrying' and h['state'] == '1']
assert gone, 'HEALTH never said degraded + gone: ' + str([(h['state'], h['last_error']) for h in health])
assert health.index(gone[0]) > health.index(missing[0])
last = health[-1]
assert last['state'] == '0', last  # back after the replug
assert int(last['parse_errors']) == 3, last   # cut DIST, nan RANGE, overlong line
assert int(last['drops']) == 1, last          # POS with qf 0
assert int(last['msgs_in']) == 10, last       # lines read (the overlong one never became a line)
assert int(last['msgs_out']) == 15, last      # 13 ranges + 2 positions
print(f'ok: listen mode: {len(ranges)} ranges and {len(poses)} positions exactly; '
      f'HEALTH said missing, then gone, then OK; parse_errors 3, drops 1')
PY
grep -q "skipped line: DIST: says 3 anchors, line has 2" "$WORK/listen.err" ||
  fail "the garbled line's reason is not in the log: $(cat "$WORK/listen.err")"

# --- 2: --pans-shell ---------------------------------------------------------------------------
lcm-logger -q -f "$WORK/shell.lcm" & logger=$!; pids+=($logger)
logger_sync "$WORK/shell.lcm"
DEV="$WORK/ttyPANS"
python3 "$FAKE" shell "$DEV" "$WORK" & fake=$!; pids+=($fake)
for ((i = 0; i < 1200; i++)); do [ -L "$DEV" ] && break; sleep 0.05; done
"$BIN/ips-uwb-serial" --device "$DEV" --tag 0C1D --pans-shell 2>"$WORK/shell.err" & drv=$!
pids+=($drv)
wait_file "$WORK/streaming" 60
published "$WORK/shell.lcm" POSE_UWB_MODULE 3
stop $drv ips-uwb-serial
wait $fake || fail "the fake DWM1001 failed"
forget $fake
logger_sync "$WORK/shell.lcm"
stop $logger lcm-logger
python3 - "$WORK/received.bin" <<'PY' || fail "the shell conversation"
import sys
got = open(sys.argv[1], 'rb').read()
want = b'\r\rlec\rlec\rquit\r'
assert got == want, f'the tag received {got!r}, expected {want!r}'
print(f'ok: the tag received {got!r}')
PY
"$BIN/ips-export" "$WORK/shell.lcm" --out "$WORK/shell-csv" >/dev/null || fail "ips-export"
python3 - "$WORK/shell-csv" <<'PY' || fail "--pans-shell: published messages"
import csv, sys
d = sys.argv[1]
rows = lambda ch: list(csv.DictReader(open(f'{d}/{ch}.csv')))
got = [(r['tag_id'], r['anchor_id'], float(r['range_m']), int(r['seq'])) for r in rows('UWB_RANGE')]
want = [('0C1D', '1151', 6.44, 0), ('0C1D', '0CA8', 6.50, 0), ('0C1D', '1151', 6.40, 1),
        ('0C1D', '0CA8', 6.52, 1), ('0C1D', '1151', 6.38, 2), ('0C1D', '0CA8', 6.55, 2)]
assert got == want, f'UWB_RANGE:\n got  {got}\n want {want}'
poses = [(float(p['position_x_m']), float(p['position_y_m']), float(p['position_z_m']))
         for p in rows('POSE_UWB_MODULE')]
assert poses == [(2.55, 2.01, 1.71), (2.56, 2.02, 1.70), (2.57, 2.03, 1.69)], poses
last = [h for h in rows('HEALTH') if h['source'] == 'ips-uwb-serial'][-1]
assert last['parse_errors'] == '0' and last['state'] == '0', last  # the banner is no error
print('ok: --pans-shell: 6 ranges and 3 positions; the banner was not counted as errors')
PY
