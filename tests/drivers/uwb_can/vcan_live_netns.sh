#!/usr/bin/env bash
# ips-uwb-can on a real SocketCAN bus: a virtual CAN interface (vcan0, CAN FD MTU) in a private
# network namespace, frames sent with can-utils' cansend, ranges published over real LCM
# multicast and recorded by lcm-logger:
#  - two classic range frames and one CAN FD range frame become three uwb_range_t with the right
#    tag and anchor ids, ranges, quality, seq and a kernel receive time;
#  - another device's frame and an extended-id frame are ignored; a 2-byte frame on an anchor id
#    is one parse error in HEALTH;
#  - SIGINT ends it with status 0.
# Exit 77 (skipped, with the reason) when no network namespace can be made, when the kernel has
# no vcan (no CAN support at all on some machines), or when cansend (Debian package can-utils) is
# not installed.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
if ! command -v cansend >/dev/null 2>&1; then
  echo "SKIP: cansend is not installed (Debian package can-utils)"
  exit 77
fi
source "$ROOT/tests/integration/live_test_lib.sh"
if ! err=$(ip link add dev vcan0 type vcan 2>&1); then
  echo "SKIP: this kernel has no virtual CAN (ip link add dev vcan0 type vcan: $err)"
  exit 77
fi
ip link set vcan0 mtu 72  # CANFD_MTU: CAN FD frames too
ip link set up vcan0
export PYTHONPATH="$HERE:$ROOT/tests/integration"

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
lcm-logger -q -f -c '^(UWB_RANGE|HEALTH|IPS_BUS_CHECK_[0-9]+)$' "$WORK/out.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-uwb-can" --interface vcan0 --fd --anchor-id 4=hall-east --log-level warn &
uwb=$!; pids+=($uwb)
"$BIN/ips-bus-check" --wait-for ips-uwb-can --timeout 60 || fail "ips-uwb-can did not come up"
logger_sync "$WORK/out.lcm"
t0=$(date +%s%6N)
cansend vcan0 301#0100E80300006407      # anchor 1 (A1), tag 1, 1000 mm, quality 100 %, seq 7
cansend vcan0 123#DEADBEEF              # another device
cansend vcan0 12345678#0100E80300006407 # an extended id: not a range frame
cansend vcan0 302#0100                  # 2 bytes on anchor 2's id: a parse error
cansend vcan0 302#2A00393000003205      # anchor 2, tag 42, 12345 mm, 50 %, seq 5
cansend vcan0 304##1FFFFF4010000FFFF    # CAN FD, BRS: anchor 4 (hall-east), tag 65535, 500 mm, no quality, seq 255
t1=$(date +%s%6N)
# One more HEALTH, counting the six frames (at most 60 s).
python3 "$HERE/../health_wait.py" "$WORK/out.lcm" --source ips-uwb-can --msgs-in 6 --after "$t1" ||
  fail "no HEALTH counting the frames"
kill -INT $uwb
rc=0; wait $uwb || rc=$?
[ "$rc" -eq 0 ] || fail "ips-uwb-can exited with $rc after SIGINT"
logger_sync "$WORK/out.lcm"
kill -INT $logger; wait $logger || true; pids=()

python3 - "$WORK/out.lcm" "$t0" "$t1" <<'PY' || fail "published ranges"
import math, sys, lcm_log, lcm_messages
evs, _, _ = lcm_log.events(sys.argv[1])
t0, t1 = int(sys.argv[2]), int(sys.argv[3])
r = [lcm_messages.uwb_range(d) for c, _, d in evs if c == 'UWB_RANGE']
want = [('T1', 'A1', 1.000, 1.0, 7), ('T42', 'A2', 12.345, 0.5, 5), ('T65535', 'hall-east', 0.5, None, 255)]
assert len(r) == 3, r
for m, (tag, anchor, rng, q, seq) in zip(r, want):
    assert (m['tag_id'], m['anchor_id'], m['seq']) == (tag, anchor, seq), m
    assert abs(m['range_m'] - rng) < 1e-9, m
    assert (math.isnan(m['quality']) if q is None else abs(m['quality'] - q) < 1e-6), m
    assert m['source'] == 'ips-uwb-can:vcan0', m
    assert t0 - 1000000 <= m['utime'] <= t1 + 1000000, m  # kernel receive time, host clock
h = [lcm_messages.health(d) for c, _, d in evs if c == 'HEALTH']
h = [x for x in h if x['source'] == 'ips-uwb-can'][-1]
assert h['msgs_in'] == 6 and h['msgs_out'] >= 3 and h['parse_errors'] == 1, h
print(f'ok: 3 ranges from vcan0 (classic and CAN FD), others ignored, HEALTH {h}')
PY
echo PASS
