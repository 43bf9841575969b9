#!/usr/bin/env bash
# ips-phone-imu end to end in a private network namespace: the real program receiving UDP CSV
# datagrams (IMU+GPS-Stream format, from a python3 socket) and Sensor Logger HTTP Push POSTs
# (python3 http.client) on loopback, real LCM multicast, the real lcm-logger recording.
#  - exact IMU messages: values (deg/s -> rad/s with --gyro-unit deg/s on UDP), NaN for a sensor
#    absent, device ids (sender address, JSON deviceId), device_utime = the phone's time, utime
#    = phone time + offset within the send/receive bounds (each utime between the send time
#    minus the smallest delay and the reception);
#  - bad datagrams and a bad JSON body counted in HEALTH parse_errors with the reason in
#    last_error; 404, 405, 413 (an oversized body refused before it is sent), 400 answered;
#  - a flood of 20000 datagrams does not grow the resident memory by more than 8 MiB, and each
#    of them is published or counted as dropped (receive queue full);
#  - SIGINT ends the program with status 0.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

lcm-logger -q -f "$WORK/imu.lcm" & logger=$!; pids+=($logger)
# The logger starts first: subscribed by the time of logger_sync (whose first probe is then kept).
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
logger_sync "$WORK/imu.lcm"
"$BIN/ips-phone-imu" --udp-port 47001 --gyro-unit deg/s --http-port 47002 --max-body-bytes 65536 \
  2>"$WORK/driver.err" & drv=$!; pids+=($drv)
for ((i = 0; i < 1200; i++)); do grep -q "HTTP push on" "$WORK/driver.err" 2>/dev/null && break; sleep 0.05; done

python3 - "$WORK" "$drv" "$HERE/.." <<'PY' || fail "the sender: $(cat "$WORK/driver.err")"
import http.client, json, socket, sys, time
work, pid = sys.argv[1], int(sys.argv[2])
sys.path.insert(0, sys.argv[3])
import health_wait
udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
times = {}
def send_udp(text):
    t0 = time.time_ns() // 1000
    udp.sendto(text.encode(), ('127.0.0.1', 47001))
    return t0
# Phone time since boot, in s; the gyroscope in deg/s.
times['u1'] = send_udp('890.71558, 3, 0.076, 9.809, 0.565, 4, 90, -45, 180, 5, -21.660,-36.960,-28.140')
time.sleep(0.05)
times['u2'] = send_udp('890.76558, 3, 0.1, 9.8, 0.5')
time.sleep(0.05)
send_udp('890.8, 9, 1, 2, 3')        # unknown sensor id
send_udp('not a datagram')            # bad time
time.sleep(0.2)

def post(path, body, method='POST'):
    c = http.client.HTTPConnection('127.0.0.1', 47002, timeout=60)
    c.request(method, path, body=body, headers={'Content-Type': 'application/json'})
    r = c.getresponse()
    out = (r.status, r.read().decode())
    c.close()
    return out
batch = {'messageId': 0, 'sessionId': 's1', 'deviceId': 'pixel-7',
         'payload': [
             {'name': 'totalacceleration', 'time': 1698501144401773000,
              'values': {'x': 0.25, 'y': 9.75, 'z': 0.5}},
             {'name': 'gyroscope', 'time': 1698501144400000000,
              'values': {'x': 0.01, 'y': 0.02, 'z': -0.03}},
             {'name': 'location', 'time': 1698501144400000000, 'values': {'latitude': 50}},
             {'name': 'totalacceleration', 'time': 1698501144411773000,
              'values': {'x': 0.5, 'y': 9.5, 'z': 1.0}},
             {'name': 'gyroscope', 'time': 1698501144412000000, 'values': {'x': 1}}]}
times['h1'] = time.time_ns() // 1000
st, body = post('/data', json.dumps(batch))
times['h1_end'] = time.time_ns() // 1000  # answered: the driver has read the batch
assert (st, json.loads(body)) == (200, {'status': 'ok', 'accepted': 3, 'rejected': 1}), (st, body)
st, body = post('/data', '{"payload": [1,')
assert st == 400 and 'not JSON' in body, (st, body)
assert post('/other', '{}')[0] == 404
assert post('/data', None, method='GET')[0] == 405
# Oversized: refused from its head, before the body is sent.
s = socket.create_connection(('127.0.0.1', 47002))
s.sendall(b'POST /data HTTP/1.1\r\nHost: x\r\nContent-Length: 2000000\r\n\r\n')
reply = s.recv(4096).decode()
s.close()
assert reply.startswith('HTTP/1.1 413 Content Too Large\r\n'), reply
# The 404's report must reach a HEALTH before the probe after the flood puts its own last_error
# (a loop busy with the flood may publish no HEALTH in between).
missing = health_wait.wait(f'{work}/imu.lcm', source='ips-phone-imu',
                           error='HTTP 404 to 127.0.0.1', timeout=60)
assert missing is None, missing

def rss_kib():
    for line in open(f'/proc/{pid}/status'):
        if line.startswith('VmRSS:'):
            return int(line.split()[1])
time.sleep(0.3)
before = rss_kib()
for k in range(20000):
    udp.sendto(b'%d.0, 3, 1, 2, 3, 4, 0, 0, 0' % (1000 + k), ('127.0.0.1', 47001))
    if k % 200 == 0:
        time.sleep(0.005)
def drained():  # until the driver has read every datagram queued on its UDP port (at most 60 s)
    end = time.time() + 60
    while time.time() < end:
        for line in open('/proc/net/udp').read().splitlines()[1:]:
            f = line.split()
            if f[1].endswith(':%04X' % 47001) and int(f[4].split(':')[1], 16) == 0:
                return
        time.sleep(0.02)
    raise AssertionError('ips-phone-imu did not read its queued datagrams within 60 s')
drained()
# The kernel reports queue drops with the next datagram received: one more, after the flood.
udp.sendto(b'999.0, 3, 1, 2, 3', ('127.0.0.1', 47001))
time.sleep(0.2)
after = rss_kib()
drained()
json.dump({'times': times, 'rss_before': before, 'rss_after': after,
           'handled': time.time_ns() // 1000}, open(f'{work}/sent.json', 'w'))
assert after - before < 8192, f'RSS grew from {before} to {after} KiB during the flood'
PY
# A HEALTH stamped after the driver had read the probe: it counts everything (at most 60 s).
handled=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["handled"])' "$WORK/sent.json")
python3 "$HERE/../health_wait.py" "$WORK/imu.lcm" --source ips-phone-imu --after "$handled" ||
  fail "no HEALTH after the flood: $(cat "$WORK/driver.err")"
stop $drv ips-phone-imu
logger_sync "$WORK/imu.lcm"
stop $logger lcm-logger

python3 - "$WORK" <<'PY' || fail "published messages or HEALTH"
import json, math, sys
from lcm_log import events
from lcm_messages import _Reader, health
work = sys.argv[1]
sent = json.load(open(f'{work}/sent.json'))
def imu(data):  # imu_t in declaration order (lcmtypes/imu_t.lcm)
    r = _Reader(data)
    return dict(utime=r.take('q'), source=r.string(), device_id=r.string(),
                device_utime=r.take('q'), accel=[r.take('d') for _ in range(3)],
                gyro=[r.take('d') for _ in range(3)], mag=[r.take('d') for _ in range(3)])
log, _, _ = events(f'{work}/imu.lcm')
msgs = [imu(d) for ch, _, d in log if ch == 'IMU']
udp = [m for m in msgs if m['device_id'] == '127.0.0.1']
web = [m for m in msgs if m['device_id'] == 'pixel-7']
hb = [health(d) for ch, _, d in log if ch == 'HEALTH']
hb = [h for h in hb if h['source'] == 'ips-phone-imu']
last = hb[-1]
# The flood: every datagram published or counted as dropped by the kernel (receive queue full).
# (lcm-logger itself may miss some of a flood on the bus: counted from HEALTH, not the log.)
kernel_drops = last['drops'] - 2 - 1  # less the 404, the 405 and the probe
flood_in = last['msgs_in'] - 4 - 5 - 1  # less the 4 datagrams before, 5 HTTP requests, the probe
assert flood_in + kernel_drops == 20000, last
assert flood_in >= 10000, f'only {flood_in} of the flood received'
# The probe's time (999 s) is older than the flood's: not newer, dropped by the assembler.
assert last['msgs_out'] == 2 + 2 + flood_in, last
flood = [m for m in udp if m['device_utime'] >= 1000000000]
assert len(flood) >= 1000 and all(m['accel'] == [1, 2, 3] and m['gyro'] == [0, 0, 0] for m in flood)
udp = [m for m in udp if m['device_utime'] < 1000000000]
assert len(udp) == 2, udp
assert all(m['source'] == 'ips-phone-imu' for m in msgs)
u1, u2 = udp[0], udp[1]
assert u1['device_utime'] == 890715580 and u2['device_utime'] == 890765580, (u1, u2)
assert u1['accel'] == [0.076, 9.809, 0.565], u1
assert u1['gyro'] == [math.pi / 2, -math.pi / 4, math.pi], u1['gyro']
assert u1['mag'] == [-21.66, -36.96, -28.14], u1
# u2 has no gyroscope or magnetometer of its own; 50 ms after u1's: within the 50 ms window.
assert u2['gyro'] == u1['gyro'] and u2['mag'] == u1['mag'], u2
# Time mapping: the offset is the least delay so far; utime never after the reception and not
# before the send. The reception is bounded by 'handled' (the driver had read every datagram by
# then), not by a fixed delay after the send, which a loaded machine can overrun.
t = sent['times']
assert t['u1'] <= u1['utime'] <= sent['handled'], (t['u1'], u1['utime'], sent['handled'])
# (The phone times are 50 ms apart, the sends a little more: u2 maps to about u1 + 50 ms.)
assert t['u1'] + 30000 <= u2['utime'] <= sent['handled'], (t, u2['utime'])
# 50 ms apart on the phone; the offset may only have come down (a quicker reading) in between,
# by as much as u1 was late to be read.
assert 0 < u2['utime'] - u1['utime'] <= 50000, (u1['utime'], u2['utime'])
assert len(web) == 2, web
w1, w2 = web
assert w1['device_utime'] == 1698501144401773 and w2['device_utime'] == 1698501144411773
assert w1['accel'] == [0.25, 9.75, 0.5] and w1['gyro'] == [0.01, 0.02, -0.03], w1
assert all(math.isnan(v) for v in w1['mag']), w1
assert w2['gyro'] == [0.01, 0.02, -0.03], w2  # the bad later gyroscope entry was skipped
# w2 is 10 ms after w1 on the phone: at most that after the answer (plus slack for the mapping).
assert t['h1'] <= w2['utime'] <= t['h1_end'] + 500000, (t['h1'], t['h1_end'], w2['utime'])
assert w2['utime'] - w1['utime'] == 10000
# Parse errors: 2 datagrams, 1 JSON entry, 1 JSON body, the 413. Drops: 404 and 405.
assert last['parse_errors'] == 5, last
errors = {h['last_error'] for h in hb}
assert 'HTTP 404 to 127.0.0.1: no such path /other (POST to /data)' in errors, errors
print(f"ok: IMU messages exact; HEALTH parse_errors 5, flood {flood_in} in + {kernel_drops} dropped; "
      f"RSS {sent['rss_before']} -> {sent['rss_after']} KiB over 20000 datagrams")
PY
# The two bad datagrams came within a second: one report (rate limit per kind), both counted.
grep -q "skipped datagram row from 127.0.0.1: unknown sensor id 9" "$WORK/driver.err" &&
  ! grep -q "not a datagram" "$WORK/driver.err" ||
  fail "the bad datagrams' report: $(cat "$WORK/driver.err")"
# 404, 405 and 413 came within a second: the first reported, the others counted.
grep -q "HTTP 404 to 127.0.0.1: no such path /other (POST to /data)" "$WORK/driver.err" &&
  ! grep -q "HTTP 413" "$WORK/driver.err" ||
  fail "the HTTP refusals' report: $(cat "$WORK/driver.err")"
