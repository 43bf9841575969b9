#!/usr/bin/env bash
# ips-phone-imu's HTTP input under abuse (issue 26), in a private network namespace, with the
# default limits (8 connections, 4 per address, 2 s header timeout, 1 MiB bodies):
# tests/integration/http_abuse.py holds a flood of 1000 connections that send nothing (from
# 127.0.0.10-17, each opened again when closed, 200 a second), sends every malformed and
# oversized case (1 MiB header line, 99999999999 and 2 MiB bodies, a body of exactly 1 MiB that
# is not JSON, garbage, NUL bytes, HTTP/0.9, HTTP/2.0, bad Content-Length, chunked junk, pipelined
# junk, resets mid-head and mid-body; 5 rounds, then 20 a second) from 127.0.0.30-37, and keeps
# 8 slow readers (127.0.0.40-41: 400 pipelined requests each, never read, 4 KiB receive buffer;
# the server answers one at a time, and its 405s are small enough for the kernel's buffers, so
# they end up idle and evicted: the eviction of a client not reading is shown by ips-view's test).
# Meanwhile 20 Sensor Logger uploads from 127.0.0.1 get their 200 within 1 s (at most one
# evicted before its request was read, see below), and after the abuse 5 more; every upload
# answered 200 reaches the bus as one IMU message, no more. The process stays up, its peak
# RSS (VmHWM) stays under 32 MiB (measured 8 MiB; 192 MiB for a sanitizer build), and the
# refusals are counted: its last log line ("HTTP connections: ...; refusals: 400 xN, ...")
# holds at least what the clients were answered, status by status, and no more 431/413/505/
# 501/417/411 than the cases that cause them were sent (http_abuse.py check); HEALTH counts
# them as drops (408, 503, 404, 405) and parse errors (the rest).
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
source "$ROOT/tests/integration/http_abuse_lib.sh"
ulimit -n 4096 2>/dev/null || true
STARVE="$ROOT/tests/integration/http_starve.py"
PORT=47104
MAX_RSS_KIB=$((32 * 1024))
if grep -qa __asan_init "$BIN/ips-phone-imu"; then MAX_RSS_KIB=$((192 * 1024)); fi

lcm-logger -q -f "$WORK/imu.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
logger_sync "$WORK/imu.lcm"
"$BIN/ips-phone-imu" --http-port $PORT 2>"$WORK/driver.err" & drv=$!; pids+=($drv)
for ((i = 0; i < 1200; i++)); do grep -q "HTTP push on" "$WORK/driver.err" 2>/dev/null && break; sleep 0.05; done
grep -q "HTTP push on" "$WORK/driver.err" || fail "ips-phone-imu did not start: $(cat "$WORK/driver.err")"

cat >"$WORK/batch.json" <<'EOF'
{"messageId": 1, "sessionId": "s", "deviceId": "abuse-phone", "payload": [
 {"name": "totalacceleration", "time": @T@, "values": {"x": 0.25, "y": 9.75, "z": 0.5}},
 {"name": "gyroscope", "time": @T@, "values": {"x": 0.01, "y": 0.02, "z": -0.03}}]}
EOF
probe() {
  python3 "$STARVE" probe $PORT --method POST --path /data --body-file "$WORK/batch.json" \
    --expect '"status":"ok","accepted":2' "$@"
}
quiet=$(probe --count 3 --every 0.05 --require) || fail "uploads without abuse: $quiet"

abuse_start $drv ips-phone-imu $PORT --get /data --post /data --stream /data \
  --body-limit 1048576 --body-limit-status 400 --rounds 5 --slow-readers 8 \
  --slow-from 127.0.0.40,127.0.0.41 --settle-s 3
# With 8 slots, a burst of 8 flood connections accepted in one turn of the loop (the loop busy
# with a 1 MiB body) can evict an upload accepted just before them, before its request is read
# (408 "no request after 0.0 s"; about 1 run in 9): at most one of the 20, and nothing else.
attacked=$(probe --count 20 --first 3 --every 0.2 --deadline 1.0 --out "$WORK/probe.json")
python3 - "$WORK/probe.json" <<'PY' || fail "uploads under abuse: $attacked; $(tail -3 "$WORK/driver.err")"
import json, sys
p = json.load(open(sys.argv[1]))
assert p['ok'] >= p['count'] - 1, p
assert all(f['status'] == 408 and 'evicted (no request after' in f['error'] for f in p['failures']), p
PY
uploaded=$((8 + $(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["ok"])' "$WORK/probe.json")))
abuse_stop $drv ips-phone-imu
after=$(probe --count 5 --first 23 --every 0.05 --deadline 1.0 --require) ||
  fail "uploads after the abuse: $after"
hwm=$(peak_rss_kib $drv)

# 3 + 20 (or 19) + 5 uploads: as many IMU messages of the device.
python3 "$HERE/../health_wait.py" "$WORK/imu.lcm" --channel IMU --contains abuse-phone \
  --count $uploaded || fail "the uploads' samples did not reach the bus: $(tail -3 "$WORK/driver.err")"
python3 "$HERE/../health_wait.py" "$WORK/imu.lcm" --source ips-phone-imu --after "$ended" ||
  fail "no HEALTH after the abuse"
stop $drv ips-phone-imu
logger_sync "$WORK/imu.lcm"
stop $logger lcm-logger
[ "$hwm" -lt "$MAX_RSS_KIB" ] || fail "peak RSS ${hwm} KiB, over ${MAX_RSS_KIB} KiB"
abuse_check "$WORK/driver.err" --handler-case body_at_limit
python3 - "$WORK" "$hwm" "$ended" "$uploaded" <<'PY' || fail "HEALTH counts"
import json, sys
from lcm_log import events
from lcm_messages import health
work, hwm, ended, uploaded = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
imu = [d for ch, _, d in events(f'{work}/imu.lcm')[0] if ch == 'IMU' and b'abuse-phone' in d]
assert len(imu) == uploaded, (len(imu), uploaded)
c = json.load(open(f'{work}/check.json'))
ref = c['server']['refusals']
hb = [health(d) for ch, _, d in events(f'{work}/imu.lcm')[0] if ch == 'HEALTH']
last = [h for h in hb if h['source'] == 'ips-phone-imu'][-1]
# Drops: the connections cut or refused a slot and the requests to no route; parse errors: the
# rest, and the bodies that are not JSON. The last HEALTH is from after the abuse: it holds at
# least what the clients were told, at most what the server counted by the end.
drops = sum(ref.get(s, 0) for s in ('404', '405', '408', '503'))
bad = sum(n for s, n in ref.items() if s not in ('404', '405', '408', '503'))
saw = c['clients_saw']
assert last['utime'] > ended, last
assert drops >= last['drops'] >= saw.get('408', 0) + saw.get('503', 0) > 100, (last, ref, saw)
assert bad + c['sent']['body_at_limit'] >= last['parse_errors'] >= \
    sum(n for s, n in saw.items() if s not in ('404', '405', '408', '503')) > 10, (last, ref, saw)
p = json.load(open(f'{work}/probe.json'))
s = c['server']
print(f"ok: {p['ok']}/{p['count']} uploads within 1 s under abuse (median "
      f"{p['latency_median_s'] * 1000:.1f} ms, max {p['latency_max_s'] * 1000:.1f} ms), "
      f"{uploaded} of {uploaded} uploads' samples on the bus; peak RSS {hwm / 1024:.1f} MiB; "
      f"{c['flood_opened']} flood connections, "
      f"{c['cases_sent']} bad requests, {c['slow_readers']} slow readers; the server: "
      f"{s['accepted']} accepted, {s['refused']} refused (503), {s['evicted']} evicted "
      f"({s['evicted_readers']} not reading), "
      f"{s['aborted']} aborted, refusals {ref}; HEALTH drops {last['drops']}, parse errors "
      f"{last['parse_errors']}")
PY
