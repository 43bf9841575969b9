#!/usr/bin/env bash
# Estimators started while the lab runs (a restart), over real LCM multicast in a private network
# namespace: ips-sim (lab, seed 1, live at 1x; SITE every 5 s) and the real lcm-logger; 6.5 s in,
# just after a periodic SITE, ips-uwb-twr, ips-uwb-tdoa, ips-aoa, ips-pdr, ips-altitude and ips-fuse
# start without --site. Each asks for the site on SITE_REQUEST and ips-sim answers at once, so
# none waits for the next periodic SITE: the time from a process's first SITE_REQUEST (it is up
# and subscribed; how long a loaded machine takes to start it is not the point) to its first
# estimate (the logger's receive times) must be within 2 s for ips-uwb-twr, ips-aoa,
# ips-altitude and ips-fuse, and within the physics of the others (docs/programs.md: the TDoA
# clocks need two syncs of each anchor, 2 s apart; PDR a first step). Exit 77 (skipped) when no
# network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
lcm-logger -q -f "$WORK/restart.lcm" & logger=$!; pids+=($logger)
logger_sync "$WORK/restart.lcm"
duration=20
"$BIN/ips-sim" --scenario lab --seed 1 --duration $duration --log-level warn & sim=$!; pids+=($sim)
python3 "$ROOT/tests/integration/log_wait.py" "$WORK/restart.lcm" --reach TRUTH \
  --end-after-site 6.5 --slack 0 --pid $sim --timeout 60
: > "$WORK/starts"
for p in ips-uwb-twr ips-uwb-tdoa ips-aoa ips-pdr ips-altitude ips-fuse; do
  echo "$p $(date +%s%6N)" >> "$WORK/starts"
  "$BIN/$p" --log-level warn & pids+=($!)
done
wait $sim; forget $sim
sleep_until_idle() {
  python3 "$ROOT/tests/integration/log_wait.py" "$WORK/restart.lcm" --reach "$1" \
    --end-after-site $duration --slack 2 --timeout 60 || true
}
sleep_until_idle POSE_FUSED
stop $logger lcm-logger

python3 - "$WORK/restart.lcm" "$WORK/starts" <<'PY' || fail "first estimates after a restart"
import struct, sys
from lcm_log import events
ev = events(sys.argv[1])[0]
starts = dict((p, int(t)) for p, t in (l.split() for l in open(sys.argv[2])))
first = {}
asked = {}  # program: the logger's time of its first SITE_REQUEST
for ch, ts, d in ev:
    first.setdefault(ch, ts)
    if ch == 'SITE_REQUEST':  # site_t: fingerprint, utime, source (the asker), ...
        n = struct.unpack_from('>i', d, 16)[0]
        asked.setdefault(d[20:20 + n - 1].decode(), ts)
bounds = {  # program: (output, bound in s)
    'ips-uwb-twr': ('POSE_UWB', 2.0), 'ips-aoa': ('POSE_AOA', 2.0),
    'ips-altitude': ('ALTITUDE', 2.0), 'ips-fuse': ('POSE_FUSED', 2.0),
    'ips-uwb-tdoa': ('POSE_TDOA', 6.0), 'ips-pdr': ('STEP', 4.5)}
bad = []
for prog, (ch, bound) in bounds.items():
    if ch not in first:
        bad.append(f'{prog}: no {ch} at all'); continue
    if prog not in asked:
        bad.append(f'{prog}: no SITE_REQUEST (asked by {sorted(asked)})'); continue
    dt = (first[ch] - asked[prog]) / 1e6
    print(f'{prog}: first {ch} {dt:.2f} s after its SITE_REQUEST, '
          f'{(asked[prog] - starts[prog]) / 1e6:.2f} s after its start (bound {bound} s)')
    if dt > bound: bad.append(f'{prog}: {dt:.2f} s > {bound} s')
assert not bad, bad
PY
echo "PASS"
