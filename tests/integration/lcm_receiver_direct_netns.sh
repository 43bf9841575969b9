#!/usr/bin/env bash
# --lcm-receiver direct (core/lcm_udpm_receiver.hpp) against liblcm's own sender and receiver,
# over real multicast in a private network namespace:
#  1. The real lcm-logplayer plays a log of messages that exercise the wire format: a 150 000-byte
#     message (three LC03 fragments), a 400 000-byte one (seven), a 1 536-byte one, an empty
#     payload, the longest channel name LCM allows, and 300 small messages. ips-record reading
#     the bus directly and the real lcm-logger (liblcm's receiver) both record them: ips-record's
#     log holds every one of them, in order, byte for byte, as lcm-logger's does.
#  2. Datagrams that are not LCM's (wrong magic, a fragment of nothing, a cut header) sent to the
#     group: ips-record counts each as a parse error in HEALTH and goes on recording.
#  3. ips-record --lcm-receiver direct says its receive buffer in HEALTH (its own socket's).
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
python3 - "$WORK/in.lcm" <<'PY'
import struct, sys
def event(n, t, ch, data):
    ch = ch.encode()
    return struct.pack('>IqqII', 0xEDA1DA01, n, t, len(ch), len(data)) + ch + data
def pattern(n, k):
    return bytes((i * k + 3) % 251 for i in range(n))
evs = [('BIG_150K', pattern(150000, 7)), ('MID_1536', pattern(1536, 5)), ('EMPTY', b''),
       ('C' * 63, b'longest channel'), ('BIG_400K', pattern(400000, 11))]
evs += [('SMALL_%d' % (i % 7), struct.pack('>q', i) * 3) for i in range(300)]
with open(sys.argv[1], 'wb') as f:
    for n, (ch, data) in enumerate(evs):
        f.write(event(n, 1_000_000 + 2000 * n, ch, data))
PY

lcm-logger "$WORK/ref.lcm" >"$WORK/logger.out" 2>&1 &
logger=$!; pids+=($logger)
"$BIN/ips-record" --out "$WORK/direct.lcm" --lcm-receiver direct --site-wait 0 --log-level warn \
  2>"$WORK/direct.err" &
rec=$!; pids+=($rec)
"$BIN/ips-bus-check" --wait-for ips-record --timeout 60 || fail "ips-record did not come up"
logger_sync "$WORK/ref.lcm"

# 1: the real player sends (liblcm's fragmentation), both receivers record.
lcm-logplayer -s 1 "$WORK/in.lcm" >/dev/null 2>&1 || fail "lcm-logplayer failed"
# 2: not LCM's.
python3 - <<'PY'
import socket, struct
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
for pkt in (b'XC02\0\0\0\1NOT_LCM\0abc', b'LC03' + b'\0' * 26, b'LC0'):
    s.sendto(pkt, ('239.255.76.67', 7667))
PY
logger_sync "$WORK/ref.lcm"
python3 "$HERE/log_wait.py" "$WORK/direct.lcm" --last-of "$WORK/in.lcm" --timeout 60 \
  || fail "ips-record did not record the last message played"
# A HEALTH of ips-record that counts the three rejected datagrams (it reports every second).
deadline=$((SECONDS + 60))
until python3 - "$WORK/ref.lcm" <<'PY'
import sys, lcm_log, lcm_messages
evs, _, _ = lcm_log.events(sys.argv[1])
hs = [lcm_messages.health(d) for c, _, d in evs if c == 'HEALTH']
hs = [h for h in hs if h['source'] == 'ips-record']
sys.exit(0 if hs and hs[-1]['parse_errors'] >= 3 else 1)
PY
do
  [ "$SECONDS" -lt "$deadline" ] || fail "no HEALTH of ips-record counting the 3 datagrams"
  sleep 0.2
done
stop $rec ips-record
stop $logger lcm-logger

python3 - "$WORK" <<'PY' || fail "the direct receiver's record differs from what was played"
import os, sys, lcm_log, lcm_messages
work = sys.argv[1]
played = [(c, d) for c, _, d in lcm_log.events(os.path.join(work, 'in.lcm'))[0]]
names = {c for c, _ in played}
for name in ('direct.lcm', 'ref.lcm'):
    evs, used, size = lcm_log.events(os.path.join(work, name))
    assert used == size, f'{name}: unreadable from byte {used} of {size}'
    got = [(c, d) for c, _, d in evs if c in names]
    assert got == played, (f'{name}: {len(got)} of {len(played)} played messages, '
                           f'first difference at {next((i for i, (a, b) in enumerate(zip(got, played)) if a != b), min(len(got), len(played)))}')
evs = lcm_log.events(os.path.join(work, 'ref.lcm'))[0]
h = [lcm_messages.health(d) for c, _, d in evs if c == 'HEALTH']
h = [x for x in h if x['source'] == 'ips-record'][-1]
assert h['recv_buf_bytes'] > 0, h
assert h['parse_errors'] == 3, h
assert 'LCM datagram dropped' in h['last_error'], h
print(f"ok: {len(played)} messages (largest {max(len(d) for _, d in played)} bytes) recorded "
      f"byte for byte by both receivers; HEALTH: parse_errors {h['parse_errors']}, "
      f"recv_buf_bytes {h['recv_buf_bytes']}, last_error {h['last_error']!r}")
PY
echo "ok: --lcm-receiver direct: liblcm's messages whole, foreign datagrams counted"
