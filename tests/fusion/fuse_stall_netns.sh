#!/usr/bin/env bash
# ips-fuse stopped for 10 s (SIGSTOP, then SIGCONT: what a swapping machine or a debugger does)
# while the lab goes on, over real LCM multicast in a private network namespace: ips-sim (lab,
# seed 1, live at 1x), ips-fuse (site from SITE) and the real lcm-logger as separate processes.
# After the pause no POSE_FUSED may lie more than 1 m from the truth with a covariance whose
# 2-sigma ellipse does not cover its error; the track restarts from fresh measurements (the pose
# after the gap is flagged REINITIALISED) and ips-fuse's HEALTH says so. Exit 77 (skipped) when no
# network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
lcm-logger -q -f "$WORK/stall.lcm" & logger=$!; pids+=($logger)
# A small receive buffer (64 KiB): the pause overflows it, as it overflows a loaded machine's, so
# ips-fuse resumes on fresh messages with most of the 10 s lost (a 4 MiB buffer keeps them all
# and ips-fuse just catches up, late).
"$BIN/ips-fuse" --log-level warn --lcm-url "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=65536" &
fuse=$!; pids+=($fuse)
"$BIN/ips-bus-check" --wait-for ips-fuse --timeout 60 || fail "ips-fuse did not come up"
logger_sync "$WORK/stall.lcm"
duration=32
"$BIN/ips-sim" --scenario lab --seed 1 --duration $duration --log-level warn & sim=$!; pids+=($sim)
# ips-fuse tracks the tag (8 s of the walk) ...
python3 "$ROOT/tests/integration/log_wait.py" "$WORK/stall.lcm" --reach POSE_FUSED \
  --end-after-site 8 --pid $fuse --timeout 60
# ... then stands still for 10 s of wall time (the pause is the stimulus, not a wait).
kill -STOP $fuse
stopped_at=$(date +%s.%N)
sleep 10
kill -CONT $fuse
echo "ips-fuse stopped for $(echo "$(date +%s.%N) - $stopped_at" | bc) s"
wait $sim; forget $sim
python3 "$ROOT/tests/integration/log_wait.py" "$WORK/stall.lcm" --reach POSE_FUSED \
  --end-after-site $duration --pid $fuse --or-idle ips-fuse
stop $fuse ips-fuse
stop $logger lcm-logger

python3 - "$WORK/stall.lcm" <<'PY' || fail "poses after the pause"
import bisect, math, struct, sys
from lcm_log import events
from lcm_messages import health
ev = events(sys.argv[1])[0]

def pose(d):  # pose_t: fingerprint, utime, source, tag_id, position[3], position_cov[9], ...
    o = 8
    t = struct.unpack_from('>q', d, o)[0]; o += 8
    for _ in range(2):
        n = struct.unpack_from('>i', d, o)[0]; o += 4 + n
    pos = struct.unpack_from('>3d', d, o); o += 24
    cov = struct.unpack_from('>9d', d, o); o += 72
    o += 24 + 8 + 4 + 8
    status = struct.unpack_from('>i', d, o)[0]
    return t, pos, cov, status

truth = sorted(pose(d)[:2] for ch, _, d in ev if ch == 'TRUTH')
tt = [t for t, _ in truth]
def truth_at(t):
    i = bisect.bisect_left(tt, t)
    if i == 0 or i == len(tt): return None
    (t0, a), (t1, b) = truth[i - 1], truth[i]
    f = (t - t0) / (t1 - t0)
    return [a[k] + f * (b[k] - a[k]) for k in range(2)]

fused = [pose(d) for ch, ts, d in ev if ch == 'POSE_FUSED']
assert len(fused) > 100, f'only {len(fused)} POSE_FUSED'
# The messages lost in the pause: the longest stretch of message time without POSE_FUSED.
gap, at = max((fused[i + 1][0] - fused[i][0], i) for i in range(len(fused) - 1))
assert gap > 5e6, f'no pause seen in POSE_FUSED (longest gap {gap / 1e6:.1f} s)'
print(f'POSE_FUSED: {gap / 1e6:.1f} s of message time without a pose')
after = fused[at + 1:]
worst, bad, scored = 0.0, [], 0
for t, pos, cov, status in after:
    tr = truth_at(t)
    if tr is None: continue
    scored += 1
    e = [pos[0] - tr[0], pos[1] - tr[1]]
    err = math.hypot(*e)
    a, b, c = cov[0], cov[1], cov[4]
    det = a * c - b * b
    m2 = (c * e[0] ** 2 - 2 * b * e[0] * e[1] + a * e[1] ** 2) / det if det > 0 else math.inf
    worst = max(worst, err)
    if err > 1.0 and m2 > 4.0:
        bad.append((t, round(err, 2), round(m2, 1), round(math.sqrt(a + c), 2)))
print(f'after the pause: {len(after)} poses, {scored} scored, worst error {worst:.2f} m; '
      f'first status {after[0][3]}')
assert scored > 50, 'too few poses after the pause'
assert not bad, f'{len(bad)} poses more than 1 m off outside their 2-sigma ellipse: {bad[:5]}'
assert after[0][3] & 16, f'the first pose after the pause is not flagged REINITIALISED: {after[0][3]}'
mine = [health(d) for ch, _, d in ev if ch == 'HEALTH' and health(d)['source'] == 'ips-fuse']
said = [h['last_error'] for h in mine if 'without input' in h['last_error']]
assert said, 'ips-fuse HEALTH never said the track restarted after the gap: ' + str(
    sorted({h['last_error'] for h in mine}))
print('HEALTH:', said[0])
PY
echo "PASS"
