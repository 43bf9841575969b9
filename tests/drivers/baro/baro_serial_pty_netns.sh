#!/usr/bin/env bash
# ips-baro end to end on a serial line: the real program reading a fake microcontroller on a
# pseudo-terminal (fake_baro_serial.py on the master side), real LCM multicast in a private
# network namespace, the real lcm-logger recording, the log read back by an independent decoder.
#  - the good lines (CRLF, LF, extra blanks, H absent, fields in another order, a line in two
#    writes) are published exactly: values, sensor id, source, reference flag and the height given
#    on the command line (--reference R1=2.4), the host time each line was read;
#  - the comment line is no sample and no error; the four bad lines (0 Pa, nan, 120 %, garbage)
#    are not published and are counted in HEALTH parse_errors; the first reason is logged, the
#    next two within the same second are held back and counted in the following report;
#  - unplugged: HEALTH says degraded and "device ... gone; retrying"; the line cut by the unplug
#    is not published; after the replug the new lines are, and HEALTH is ok again;
#  - SIGINT ends the program with status 0.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

lcm-logger -q -f "$WORK/baro.lcm" & logger=$!; pids+=($logger)
# The logger starts first: subscribed by the time of logger_sync (whose first probe is then kept).
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"

logger_sync "$WORK/baro.lcm"
LINK="$WORK/ttyBARO0"
python3 "$HERE/fake_baro_serial.py" "$LINK" "$WORK/driver.err" "$WORK" & fake=$!; pids+=($fake)
for ((i = 0; i < 1200; i++)); do [ -L "$LINK" ] && break; sleep 0.05; done
"$BIN/ips-baro" --serial "R1=$LINK" --reference R1=2.4 --reopen-s 0.2 2>"$WORK/driver.err" &
drv=$!; pids+=($drv)
for ((i = 0; i < 2400; i++)); do [ -e "$WORK/done" ] && break; sleep 0.05; done
[ -e "$WORK/done" ] || { wait $fake || true; fail "the fake barometer did not finish: $(cat "$WORK/driver.err")"; }
python3 "$HERE/../health_wait.py" "$WORK/baro.lcm" --channel BARO --count 5 ||
  fail "the last samples were not published: $(cat "$WORK/driver.err")"
stop $drv ips-baro
touch "$WORK/stop"
wait $fake || fail "the fake barometer failed"
forget $fake
logger_sync "$WORK/baro.lcm"
stop $logger lcm-logger

reason() { grep -cF "ips-baro: skipped line from R1 ($LINK): $1" "$WORK/driver.err" || true; }
[ "$(reason "pressure 0 Pa is not positive")" -eq 1 ] ||
  fail "the first bad line's reason is not logged once: $(cat "$WORK/driver.err")"
[ "$(reason "unknown field 'garbage??' (expected P, T or H) (2 more like it since the last report)")" -eq 1 ] ||
  fail "the held-back count is not in the next report: $(cat "$WORK/driver.err")"
[ "$(reason "temperature")" -eq 0 ] && [ "$(reason "humidity")" -eq 0 ] ||
  fail "a bad line of the same second was logged: $(cat "$WORK/driver.err")"

python3 - "$WORK" "$LINK" <<'PY' || fail "BARO or HEALTH: $(cat "$WORK/driver.err")"
import json, math, sys
from lcm_log import events
from lcm_messages import _Reader, health

work, link = sys.argv[1:]

def baro(data):  # baro_t in declaration order (lcmtypes/baro_t.lcm)
    r = _Reader(data)
    return dict(utime=r.take('q'), source=r.string(), sensor_id=r.string(),
                pressure_pa=r.take('d'), temperature_c=r.take('d'), humidity_pct=r.take('d'),
                is_reference=bool(r.take('b')), known_height_m=r.take('d'))

log, _, _ = events(f'{work}/baro.lcm')
msgs = [baro(d) for ch, _, d in log if ch == 'BARO']
hb = [h for h in (health(d) for ch, _, d in log if ch == 'HEALTH') if h['source'] == 'ips-baro']
nan = float('nan')
want = [(101325.12, 21.43, 45.2), (101324.5, 21.44, nan), (101323.25, 21.46, 44.9),
        (101322.0, 21.47, nan), (101321.5, -5.5, nan)]
got = [(m['pressure_pa'], m['temperature_c'], m['humidity_pct']) for m in msgs]
same = lambda a, b: a == b or (math.isnan(a) and math.isnan(b))
assert len(got) == len(want) and all(all(map(same, g, w)) for g, w in zip(got, want)), got
for m in msgs:
    assert m['source'] == f'ips-baro:{link}' and m['sensor_id'] == 'R1', m
    assert m['is_reference'] and m['known_height_m'] == 2.4, m

# Reception time: after the write, within 2 s (the host's clock on reception: a loaded machine can
# be a fraction of a second late to read, a device's or a batch's time would be further off).
sent = {s['text']: s['t_us'] for s in json.load(open(f'{work}/sent.json'))}
keys = ['P 101325.12 T 21.43 H 45.2', 'P  101324.50\tT 21.44  ', 'P 101323.25 T 21.46 H 44.9',
        'P 101322.00 T 21.47', 'T -5.5 P 101321.5']
for m, k in zip(msgs, keys):
    assert sent[k] <= m['utime'] <= sent[k] + 2000000, (k, sent[k], m['utime'])

t_unplug, t_replug = sent['unplug'], sent['replug']
garbage = (f"skipped line from R1 ({link}): unknown field 'garbage??' (expected P, T or H) "
           '(2 more like it since the last report)')
assert any(h['state'] == 1 and h['last_error'] == garbage for h in hb), \
    [(h['state'], h['last_error']) for h in hb]
# From the first HEALTH that says so (the driver sees the hang-up when it next runs, later on a
# loaded machine) to the replug, every one says the device is gone.
said = [h['utime'] for h in hb if t_unplug < h['utime'] < t_replug and h['state'] == 1 and
        h['last_error'] == f'device {link} gone; retrying']
away = [h for h in hb if said and said[0] <= h['utime'] < t_replug]
assert away and all(h['state'] == 1 and h['last_error'] == f'device {link} gone; retrying'
                    for h in away), [(h['state'], h['last_error']) for h in hb]
last = hb[-1]
assert last['state'] == 0, last
assert last['parse_errors'] == 4, last   # 0 Pa, nan, 120 %, garbage
assert last['drops'] == 0, last
# Lines read: the comment, 2 good, 3 bad, the split line, garbage; 2 after the replug. The line
# cut by the unplug is not one.
assert last['msgs_in'] == 10, last
assert last['msgs_out'] == 5, last
print(f'ok: {len(msgs)} BARO samples exactly; 4 bad lines counted, 2 of them held back in the '
      'log; HEALTH said the device was gone while unplugged, ok after the replug')
PY
