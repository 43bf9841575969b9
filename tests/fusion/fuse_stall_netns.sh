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
stopped_s=$(echo "$(date +%s.%N) - $stopped_at" | bc)
echo "ips-fuse stopped for $stopped_s s"
wait $sim; forget $sim
python3 "$ROOT/tests/integration/log_wait.py" "$WORK/stall.lcm" --reach POSE_FUSED \
  --end-after-site $duration --pid $fuse --or-idle ips-fuse
stop $fuse ips-fuse
stop $logger lcm-logger

# Counts are relative to what happened in this run (where the pause fell in the walk, the pause's
# wall time, the poses' own period), not fixed numbers a loaded machine can miss. Times are printed
# as seconds of message time after the SITE, so that a failure can be replayed (ips-replay on the
# walk with the inputs between the two pause ends cut out).
python3 - "$WORK/stall.lcm" "$stopped_s" <<'PY' || fail "poses after the pause"
import bisect, math, struct, sys
from lcm_log import events
from lcm_messages import health
ev = events(sys.argv[1])[0]
stopped_s = float(sys.argv[2])

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

site = next(struct.unpack_from('>q', d, 8)[0] for ch, _, d in ev if ch == 'SITE')
def rel(t): return (t - site) / 1e6  # seconds of message time after the SITE

fused = [pose(d) for ch, ts, d in ev if ch == 'POSE_FUSED']
assert len(fused) > 10, f'only {len(fused)} POSE_FUSED'
# ips-fuse's own publish period: the commonest interval between its poses.
period = sorted(fused[i + 1][0] - fused[i][0] for i in range(len(fused) - 1))[len(fused) // 2]
# The messages lost in the pause: the longest stretch of message time without POSE_FUSED; most
# of the pause (the 64 KiB buffer holds well under a second of the lab's traffic).
gap, at = max((fused[i + 1][0] - fused[i][0], i) for i in range(len(fused) - 1))
assert gap > 0.5 * stopped_s * 1e6, \
    f'no pause seen in POSE_FUSED (longest gap {gap / 1e6:.1f} s, stopped {stopped_s:.1f} s)'
print(f'POSE_FUSED every {period / 1e6:.2f} s; {gap / 1e6:.1f} s of message time without a pose '
      f'from {rel(fused[at][0]):.3f} s to {rel(fused[at + 1][0]):.3f} s after the SITE')
# Before the pause and after it to the end of the walk, ips-fuse published at least half the poses
# its period allows (a track that did not start, or did not restart, publishes none).
before, after = fused[:at + 1], fused[at + 1:]
for name, part, t1 in (('before', before, before[-1][0]), ('after', after, tt[-1])):
    span = t1 - part[0][0]
    print(f'{name} the pause: {len(part)} poses in {span / 1e6:.1f} s')
    assert span > 2e6 and len(part) >= 0.5 * span / period, \
        f'{name} the pause: {len(part)} poses in {span / 1e6:.1f} s, one every {period / 1e6:.2f} s'
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
        bad.append((round(rel(t), 3), round(err, 2), round(m2, 1), round(math.sqrt(a + c), 2)))
print(f'after the pause: {len(after)} poses, {scored} scored, worst error {worst:.2f} m; '
      f'first status {after[0][3]}')
assert scored >= 0.9 * len(after), f'only {scored} of {len(after)} poses after the pause scored'
assert not bad, (f'{len(bad)} poses more than 1 m off outside their 2-sigma ellipse (s after the '
                 f'SITE, error m, squared Mahalanobis distance, sd m): {bad[:5]}')
assert after[0][3] & 16, f'the first pose after the pause is not flagged REINITIALISED: {after[0][3]}'
mine = [health(d) for ch, _, d in ev if ch == 'HEALTH' and health(d)['source'] == 'ips-fuse']
said = [h['last_error'] for h in mine if 'without input' in h['last_error']]
assert said, 'ips-fuse HEALTH never said the track restarted after the gap: ' + str(
    sorted({h['last_error'] for h in mine}))
print('HEALTH:', said[0])
PY
echo "PASS"
