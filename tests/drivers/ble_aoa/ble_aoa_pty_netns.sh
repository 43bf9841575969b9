#!/usr/bin/env bash
# ips-ble-aoa end to end: the real program serving three fake XPLR-AOA anchors at once on
# pseudo-terminals (fake_xplr_aoa.py on the master sides), real LCM multicast in a private network
# namespace, the real lcm-logger recording, the log read back by an independent decoder.
#  - --enable-events --at-command AT+UDFCFG=1,50: each anchor receives exactly ATE0, AT+UMLA=1,
#    AT+UDFCFG=1,50, AT+UDFENABLE=1 (one after the other's OK), again after a replug; anchor C
#    answers ERROR to AT+UDFCFG=1,50: the log and HEALTH name it, and C's events still count;
#  - the published BLE_AOA messages are exactly the expected ones: ids (B's renamed to A2 by
#    --anchor-name), angles (B is older firmware, 0..180 deg, --angle-range auto), RSSI, channel,
#    uptime, seq (-1 without a counter), raw user strings, source per device, reception time;
#  - A's garbled first lines are parse errors, A's repeated counter and B's repeated line are
#    dropped, B's first (undecidable) event is dropped: HEALTH parse_errors 2, drops 3;
#  - A unplugged: HEALTH says degraded + "device ... gone; retrying" while B keeps publishing;
#    after the replug A's new events are published and the line cut by the unplug is not;
#  - SIGINT ends the program with status 0.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

lcm-logger -q -f "$WORK/aoa.lcm" & logger=$!; pids+=($logger)
# The logger starts first: subscribed by the time of logger_sync (whose first probe is then kept).
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"

logger_sync "$WORK/aoa.lcm"
A="$WORK/ttyAOA0" B="$WORK/ttyAOA1" C="$WORK/ttyAOA2"
python3 "$HERE/fake_xplr_aoa.py" "$A" "$B" "$C" "$WORK/driver.err" "$WORK" & fake=$!; pids+=($fake)
for ((i = 0; i < 1200; i++)); do [ -L "$A" ] && [ -L "$B" ] && [ -L "$C" ] && break; sleep 0.05; done
"$BIN/ips-ble-aoa" --device "$A" --device "$B" --device "$C" --enable-events \
  --at-command AT+UDFCFG=1,50 --angle-range auto --anchor-name 6C1DEBA0AAAA=A2 --reopen-s 0.2 \
  2>"$WORK/driver.err" & drv=$!; pids+=($drv)
for ((i = 0; i < 2400; i++)); do [ -e "$WORK/done" ] && break; sleep 0.05; done
[ -e "$WORK/done" ] || { wait $fake || true; fail "the fake anchors did not finish: $(cat "$WORK/driver.err")"; }
python3 "$HERE/../health_wait.py" "$WORK/aoa.lcm" --channel BLE_AOA --count 14 ||
  fail "the last events were not published: $(cat "$WORK/driver.err")"
stop $drv ips-ble-aoa
touch "$WORK/stop"
wait $fake || fail "the fake anchors failed"
forget $fake
logger_sync "$WORK/aoa.lcm"
stop $logger lcm-logger

grep -q "skipped line from $A: not a +UUDF event or an AT response" "$WORK/driver.err" ||
  fail "the garbled line's reason is not in the log: $(cat "$WORK/driver.err")"
grep -q "$C: the anchor answered ERROR to AT+UDFCFG=1,50" "$WORK/driver.err" ||
  fail "the refused command is not in the log: $(cat "$WORK/driver.err")"
grep -q "$A: the anchor says +UMLA:6C1DEBA09862p" "$WORK/driver.err" ||
  fail "the anchor's address is not in the log: $(cat "$WORK/driver.err")"

python3 - "$WORK" "$A" "$B" "$C" <<'PY' || fail "published messages, HEALTH or the AT conversation"
import json, struct, sys
from lcm_log import events
from lcm_messages import _Reader, health

work, dev_a, dev_b, dev_c = sys.argv[1:]

def ble_aoa(data):  # ble_aoa_t in declaration order (lcmtypes/ble_aoa_t.lcm)
    r = _Reader(data)
    return dict(utime=r.take('q'), source=r.string(), anchor_id=r.string(), tag_id=r.string(),
                azimuth=r.take('f'), elevation=r.take('f'), rssi=r.take('f'), channel=r.take('h'),
                uptime=r.take('q'), seq=r.take('i'), user=r.string())

log, _, _ = events(f'{work}/aoa.lcm')
msgs = [ble_aoa(d) for ch, _, d in log if ch == 'BLE_AOA']
hb = [health(d) for ch, _, d in log if ch == 'HEALTH']
hb = [h for h in hb if h['source'] == 'ips-ble-aoa']

# The received bytes: the conversation, one command after the other's OK.
received = json.load(open(f'{work}/received.json'))
conv = 'ATE0\rAT+UMLA=1\rAT+UDFCFG=1,50\rAT+UDFENABLE=1\r'
assert received == {'A': [conv, conv], 'B': [conv], 'C': ['ATE0\rAT+UMLA=1\rAT+UDFCFG=1,50\r']}, received

key = lambda m: (m['anchor_id'], m['tag_id'], m['azimuth'], m['elevation'], m['rssi'],
                 m['channel'], m['uptime'], m['seq'], m['user'])
by_source = lambda dev: [key(m) for m in msgs if m['source'] == 'ips-ble-aoa:' + dev]
want_a = [('6C1DEBA09862', '6C1DEBA5F60C', -30, 42, -68, 37, 1606101, 25, ''),
          ('6C1DEBA09862', '6C1DEBA5F60C', -28, 40, -67, 38, 1606201, 26, ''),
          ('6C1DEBA09862', '6C1DEBA5F60C', -25, 41, -69, 39, 1606301, 27, ''),
          ('6C1DEBA09862', '6C1DEBA5F60C', -10, 30, -66, 37, 1200, 0, ''),
          ('6C1DEBA09862', '6C1DEBA5F60C', -5, 31, -65, 38, 1300, 1, '')]
# B: raw 0..180 deg -> raw - 90; nine fields -> seq -1; renamed to A2.
want_b = ([('A2', '6C1DEBA5F60D', 30, 5, -72, 38, 5100, -1, ''),
           ('A2', '6C1DEBA5F60D', 10, 0, -73, 39, 5200, -1, '')] +
          [('A2', '6C1DEBA5F60D', 1 + k, -10, -70, 37, 6000 + 100 * k, -1, '') for k in range(5)])
want_c = [('6C1DEBA0CCCC', '6C1DEBA5F60C', 5, -3, -60, 37, 777, 7, 'lat,50.1'),
          ('6C1DEBA0CCCC', '6C1DEBA5F60C', 6, -2, -61, 38, 877, 8, '\x1b[2J')]
for dev, want in ((dev_a, want_a), (dev_b, want_b), (dev_c, want_c)):
    got = by_source(dev)
    assert got == want, f'{dev}:\n got  {got}\n want {want}'
assert len(msgs) == 14, len(msgs)

# Reception time: after the write, within 2 s (the host's clock on reception: a loaded machine can
# be a fraction of a second late to read, the board's uptime would be far off).
sent = json.load(open(f'{work}/sent.json'))
t_sent = {(s['anchor'], s['text']): s['t_us'] for s in sent}
first_a = next(m for m in msgs if m['seq'] == 25)
t = t_sent[('A', '+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,"6C1DEBA09862","",1606101,25')]
assert t <= first_a['utime'] <= t + 2000000, (t, first_a['utime'])
# B kept publishing while A was unplugged.
t_unplug, t_replug = t_sent[('A', 'unplug')], t_sent[('A', 'replug')]
during = [m for m in msgs if m['source'] == 'ips-ble-aoa:' + dev_b and t_unplug < m['utime'] < t_replug]
assert len(during) == 5, [m['utime'] for m in msgs]
gone = [h for h in hb if h['last_error'] == f'device {dev_a} gone; retrying' and h['state'] == 1]
assert gone and any(t_unplug < h['utime'] < t_replug for h in gone), \
    'HEALTH never said A was gone: ' + str([(h['state'], h['last_error']) for h in hb])
assert any(h['last_error'] == f'{dev_c}: the anchor answered ERROR to AT+UDFCFG=1,50' for h in hb), \
    'HEALTH never named the refused command'
last = hb[-1]
assert last['parse_errors'] == 2, last   # A's two garbled first lines
assert last['drops'] == 3, last          # A's repeated counter, B's repeated line, B's undecidable
# Lines read: A 2 garbled + 2x6 of the conversation (echoed ATE0, OK, +UMLA, OK, OK, OK) + 4 + 2
# events; B 6 + 4 + 5; C 5 (ATE0 echo, OK, +UMLA, OK, ERROR) + 2. The line cut by the unplug is not.
assert last['msgs_in'] == 20 + 15 + 7, last
assert last['msgs_out'] == 14, last
print(f'ok: {len(msgs)} BLE_AOA messages exactly from 3 anchors; the AT conversations; HEALTH '
      f'said A was gone while B published 5 events; parse_errors 2, drops 3')
PY
