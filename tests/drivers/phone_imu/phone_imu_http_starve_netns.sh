#!/usr/bin/env bash
# ips-phone-imu's HTTP input cannot be starved (issue 28), in a private network namespace: with
# 200 connections held open that send nothing (from 127.0.0.2 and 127.0.0.3, each opened again
# as soon as the server closes it) and a slowloris of 10 connections (127.0.0.4: a request head
# a byte every 0.5 s, opened again when cut), 20 Sensor Logger uploads from 127.0.0.1 (each a
# new connection, every 0.2 s) all get their 200 within 1 s, their samples reach the bus (20
# IMU messages of the device), and HEALTH tells the connections cut ("connections so far: ...").
# Default limits (8 connections, 4 per address, 2 s header timeout). Prints the latencies.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
ulimit -n 4096 2>/dev/null || true
STARVE="$ROOT/tests/integration/http_starve.py"
PORT=47102

lcm-logger -q -f "$WORK/imu.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
logger_sync "$WORK/imu.lcm"
"$BIN/ips-phone-imu" --http-port $PORT 2>"$WORK/driver.err" & drv=$!; pids+=($drv)
for ((i = 0; i < 1200; i++)); do grep -q "HTTP push on" "$WORK/driver.err" 2>/dev/null && break; sleep 0.05; done
grep -q "HTTP push on" "$WORK/driver.err" || fail "ips-phone-imu did not start: $(cat "$WORK/driver.err")"

# One accelerometer and one gyroscope reading per upload, 10 ms of phone time after the last.
cat >"$WORK/batch.json" <<'EOF'
{"messageId": 1, "sessionId": "s", "deviceId": "starve-phone", "payload": [
 {"name": "totalacceleration", "time": @T@, "values": {"x": 0.25, "y": 9.75, "z": 0.5}},
 {"name": "gyroscope", "time": @T@, "values": {"x": 0.01, "y": 0.02, "z": -0.03}}]}
EOF
probe() {
  python3 "$STARVE" probe $PORT --method POST --path /data --body-file "$WORK/batch.json" \
    --expect '"status":"ok","accepted":2' "$@"
}
quiet=$(probe --count 3 --every 0.05 --require) || fail "uploads without an attack: $quiet"

python3 "$STARVE" attack $PORT --ready "$WORK/ready" --stats "$WORK/attack.json" \
  --idle 200 --idle-from 127.0.0.2,127.0.0.3 --slow 10 --slow-from 127.0.0.4 & atk=$!
pids+=($atk)
for ((i = 0; i < 1200; i++)); do [ -s "$WORK/ready" ] && break; sleep 0.05; done
[ -s "$WORK/ready" ] || fail "the attack did not open its connections within 60 s"
# Uploads 4 s long: the slowloris is cut (2 s) and comes back meanwhile.
attacked=$(probe --count 20 --first 3 --every 0.2 --deadline 1.0 --require --out "$WORK/probe.json") ||
  fail "uploads under attack: $attacked; $(tail -3 "$WORK/driver.err")"
kill -TERM $atk
wait $atk || fail "the attack process failed"
forget $atk

# 3 + 20 uploads: as many IMU messages of the device; HEALTH tells the connections cut.
python3 "$HERE/../health_wait.py" "$WORK/imu.lcm" --channel IMU --contains starve-phone \
  --count 23 || fail "the uploads' samples did not reach the bus: $(tail -3 "$WORK/driver.err")"
python3 "$HERE/../health_wait.py" "$WORK/imu.lcm" --source ips-phone-imu \
  --error "connections so far:" || fail "no HEALTH telling the connections cut"
stop $drv ips-phone-imu
logger_sync "$WORK/imu.lcm"
stop $logger lcm-logger
python3 - "$WORK" <<'PY' || fail "HEALTH counts"
import json, sys
from lcm_log import events
from lcm_messages import health
work = sys.argv[1]
atk = json.load(open(f'{work}/attack.json'))
hb = [health(d) for ch, _, d in events(f'{work}/imu.lcm')[0] if ch == 'HEALTH']
last = [h for h in hb if h['source'] == 'ips-phone-imu'][-1]
# Every connection the server closed is a drop (408 evicted or timed out, 503 refused).
assert last['drops'] >= atk['closed_by_server'] > 200, (last, atk)
assert last['parse_errors'] == 0, last
p = json.load(open(f'{work}/probe.json'))
print(f"ok: {p['ok']}/{p['count']} uploads within 1 s under attack (median "
      f"{p['latency_median_s'] * 1000:.1f} ms, max {p['latency_max_s'] * 1000:.1f} ms); the "
      f"attack opened {atk['opened']} connections, {atk['closed_by_server']} closed by the "
      f"server; HEALTH drops {last['drops']}")
PY
