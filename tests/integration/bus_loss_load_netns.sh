#!/usr/bin/env bash
# No silent loss at a lab's full load, over real LCM multicast in a private network namespace:
# ips-sim publishes the lab with 50 walkers (20 in the sanitizer build, IPS_SANITIZED=1) at real
# speed, about 14 000 messages a second, and ips-record records it with its default queue and
# receive buffer. Every message the simulator published (the same seed written to a file is the
# reference) is in the recording, or the sidecar's "loss" says how many are missing: recorded +
# lost >= published, and with nothing lost nothing is missing. HEALTH of the simulator reports
# no publish failure. A second argument `direct` runs ips-record with --lcm-receiver direct (its
# own loop reads the socket, core/lcm_udpm_receiver.hpp). Exit 77 (skipped) when no network
# namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
# The bus as a user has it: our default URL, with the default receive buffer added by the node.
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0"
START=1767225600000000
WALKERS=50
[ "${IPS_SANITIZED:-0}" = "1" ] && WALKERS=20
DURATION=8
RECEIVER=${2:-liblcm}

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
"$BIN/ips-sim" --scenario lab --seed 3 --tags $WALKERS --duration $DURATION --start-utime $START \
  --out "$WORK/ref.lcm" --log-level warn
"$BIN/ips-record" --out "$WORK/rec.lcm" --site-wait 0 --log-level warn --lcm-receiver "$RECEIVER" \
  2>"$WORK/record.err" &
rec=$!; pids+=($rec)
"$BIN/ips-bus-check" --wait-for ips-record --timeout 60 || fail "ips-record did not come up"
"$BIN/ips-sim" --scenario lab --seed 3 --tags $WALKERS --duration $DURATION --start-utime $START \
  --log-level warn
# A probe sent after the simulator ended is recorded after everything it published (one socket,
# in order): once it is in the log, the rest was recorded or lost.
sync_probe() {
  local deadline=$((SECONDS + 60)) n0 i
  n0=$({ grep -ao 'IPS_BUS_CHECK_' "$WORK"/rec*.lcm 2>/dev/null || true; } | wc -l)
  while [ "$SECONDS" -lt "$deadline" ]; do
    "$BIN/ips-bus-check" --timeout 30 >/dev/null || fail "multicast does not loop back"
    for i in $(seq 40); do
      [ "$({ grep -ao 'IPS_BUS_CHECK_' "$WORK"/rec*.lcm 2>/dev/null || true; } | wc -l)" -gt "$n0" ] \
        && return 0
      sleep 0.05  # ips-record flushes every 100 ms
    done
  done
  fail "ips-record recorded no probe within 60 s"
}
sync_probe
stop $rec ips-record
python3 - "$WORK" $WALKERS "$RECEIVER" <<'PY' || fail "loss not accounted for (see above)"
import glob, json, os, sys
import lcm_log, lcm_messages
work, walkers, receiver = sys.argv[1], int(sys.argv[2]), sys.argv[3]
ref, _, _ = lcm_log.events(os.path.join(work, 'ref.lcm'))
ref = [(c, d) for c, _, d in ref if c != 'HEALTH']
rec = []
for p in sorted(glob.glob(os.path.join(work, 'rec*.lcm'))):
    evs, used, size = lcm_log.events(p)
    assert used == size, f'{p}: unreadable from byte {used} of {size}'
    rec += evs
side = json.load(open(os.path.join(work, 'rec.json')))
loss = side['loss']
sim_health = [lcm_messages.health(d) for c, _, d in rec if c == 'HEALTH']
sim_health = [h for h in sim_health if h['source'] == 'ips-sim']
assert sim_health and sim_health[-1]['drops'] == 0, 'ips-sim failed to publish some messages'
published = len(ref)
channels = {c for c, _ in ref}
got = [(c, d) for c, _, d in rec if c in channels]
# In order, unaltered: the recording is the reference with some messages (possibly none) missing.
it = iter(ref)
assert all(any(r == g for r in it) for g in got), 'a recorded message is not in the reference'
missing = published - len(got)
lost = loss['lost'] + side['dropped']
print(f'{walkers} walkers, {receiver} receiver: published {published}, recorded {len(got)}, missing {missing}; '
      f'sidecar: kernel_drops {loss["kernel_drops"]}, queue_drops {loss["queue_drops"]}, '
      f'dropped {side["dropped"]}, seq_lost {loss["seq_lost"]}, '
      f'recv_buf_bytes {loss["recv_buf_bytes"]}, lcm_queue {loss["lcm_queue"]}')
assert loss['recv_buf_bytes'] > 0, loss  # udpm: liblcm's socket was found
assert loss['lcm_queue'] == 20000, loss
assert loss['receiver'] == receiver, loss
assert missing >= 0
if lost == 0:
    assert missing == 0, f'{missing} messages missing and none reported lost'
else:
    # HEALTH and probes are lost alike: what is lost beyond the simulator's is at most those.
    assert missing <= lost, f'{missing} missing but only {lost} reported lost'
    assert lost - missing <= 10 * len(sim_health) + 20, f'{lost} reported lost, {missing} missing'
PY
echo "ok: ips-record at $WALKERS walkers ($RECEIVER receiver): every loss counted"
