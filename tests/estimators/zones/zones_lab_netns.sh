#!/usr/bin/env bash
# ips-zones on the lab scenario's zones (bench, store, entrance: config/sites/lab.yaml):
#  1. ips-sim --out (60 s, seed 1), then ips-replay --only zones on TRUTH: the events are exactly
#     the crossings of the truth path, computed independently (zone_events_check.py --exact),
#     DWELL included, and the marked ones are alerts;
#  2. ips-replay with every estimator: on POSE_FUSED every truth ENTER/LEAVE has its event within
#     0.5 s and there is none extra; twice gives byte-identical output;
#  3. live, in a private network namespace over real LCM multicast: ips-sim (30 s at 2x),
#     ips-zones on TRUTH with a site whose alert rules are 2 s, ips-aoa with a site without
#     angle-of-arrival anchors (degraded) and lcm-logger as separate processes. The events match
#     the truth crossings (within 0.1 s: a datagram may be lost); when the simulator ends, T1's
#     silence is raised 2 s after its last pose, ips-sim is gone 2 s after its last HEALTH;
#     ips-aoa's degradation is raised, and once it is stopped it is gone; ips-zones' own HEALTH
#     stays OK and is not watched;
#  4. --help, and a bad --pose-channel (status 2).
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
SITE="$ROOT/config/sites/lab.yaml"
CHECK="$HERE/zone_events_check.py"

# --- 1. TRUTH through ips-replay ---------------------------------------------------------------
"$BIN/ips-sim" --scenario lab --seed 1 --duration 60 --out "$WORK/lab.lcm" --log-level warn
"$BIN/ips-replay" "$WORK/lab.lcm" --out "$WORK/truth.lcm" --only zones \
  --zones-pose-channel TRUTH --log-level warn
python3 "$CHECK" "$SITE" "$WORK/truth.lcm" --exact || fail "zone events on TRUTH"

# --- 2. POSE_FUSED through ips-replay, deterministic ---------------------------------------------
"$BIN/ips-replay" "$WORK/lab.lcm" --out "$WORK/fused1.lcm" --log-level warn
"$BIN/ips-replay" "$WORK/lab.lcm" --out "$WORK/fused2.lcm" --log-level warn
cmp "$WORK/fused1.lcm" "$WORK/fused2.lcm" || fail "two replays of one log differ"
python3 "$CHECK" "$SITE" "$WORK/fused1.lcm" --within 0.5 || fail "zone events on POSE_FUSED"

# --- 3. live -------------------------------------------------------------------------------------
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
sed -e 's/^alerts: .*/alerts: {tag_silent_s: 2, process_silent_s: 2}/' "$SITE" >"$WORK/site.yaml"
grep -q 'tag_silent_s: 2,' "$WORK/site.yaml" || fail "could not shorten the alert rules"
cp "$ROOT/config/sites/lab-plan.svg" "$WORK/"  # the floor plan, beside the site file
# A site without BLE anchors: ips-aoa says so as a lasting error (degraded).
grep -v 'kind: ble_aoa' "$SITE" | sed -e '/^zones:/,$d' >"$WORK/no-aoa.yaml"
lcm-logger -q -f "$WORK/live.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-zones" --site "$WORK/site.yaml" --pose-channel TRUTH --log-level warn \
  2>"$WORK/zones.err" & zones=$!; pids+=($zones)
"$BIN/ips-aoa" --site "$WORK/no-aoa.yaml" --log-level error & aoa=$!; pids+=($aoa)
"$BIN/ips-bus-check" --wait-for ips-zones ips-aoa --timeout 60 || fail "processes did not come up"
logger_sync "$WORK/live.lcm"
"$BIN/ips-sim" --scenario lab --seed 1 --duration 30 --speed 2 --log-level warn

# Waits (at most 60 s) until the log holds an ALERT of `kind` and `state` whose subject starts
# with `subject`.
wait_alert() {
  python3 - "$WORK/live.lcm" "$@" <<'PY' || fail "no alert $*"
import sys, time
from lcm_log import events
from lcm_messages import alert
log, kind, state, subject = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
deadline = time.time() + 60
while time.time() < deadline:
    ev, _, _ = events(log)
    if any(a['kind'] == kind and a['state'] == state and a['subject'].startswith(subject)
           for a in (alert(d) for ch, _, d in ev if ch == 'ALERT')):
        sys.exit(0)
    time.sleep(0.1)
sys.exit(1)
PY
}
wait_alert 1 1 T1            # tag silent, raised
wait_alert 3 1 ips-sim@      # process gone, raised
stop $aoa ips-aoa
wait_alert 3 1 ips-aoa@
stop $zones ips-zones
stop $logger lcm-logger

python3 "$CHECK" "$WORK/site.yaml" "$WORK/live.lcm" --within 0.1 || fail "live zone events"
python3 - "$WORK/live.lcm" <<'PY' || fail "live alerts"
import sys
from lcm_log import events
from lcm_messages import (ALERT_PROCESS_DEGRADED, ALERT_PROCESS_GONE, ALERT_RAISED,
                          ALERT_TAG_SILENT, alert, health, pose)
ev, _, _ = events(sys.argv[1])
alerts = [alert(d) for ch, _, d in ev if ch == 'ALERT']
truth = [pose(d) for ch, _, d in ev if ch == 'TRUTH']
hs = [health(d) for ch, _, d in ev if ch == 'HEALTH']
assert [a['seq'] for a in alerts] == list(range(len(alerts))), 'alert seq'
silent = [a for a in alerts if a['kind'] == ALERT_TAG_SILENT]
assert len(silent) == 1 and silent[0]['subject'] == 'T1', silent
# Raised at the moment it went silent: its last pose + tag_silent_s (the tick only notices it).
assert silent[0]['utime'] == truth[-1]['utime'] + 2_000_000, (silent[0], truth[-1]['utime'])
assert silent[0]['text'] == 'T1: no pose on TRUTH for 2.0 s', silent[0]['text']
sim_last = max(h['utime'] for h in hs if h['source'] == 'ips-sim')
gone = {a['subject'].split('@')[0]: a for a in alerts if a['kind'] == ALERT_PROCESS_GONE}
# (ips-bus-check, which the test runs, is gone too when its --wait-for took 2 s or more.)
assert {'ips-sim', 'ips-aoa'} <= set(gone) <= {'ips-sim', 'ips-aoa', 'ips-bus-check'}, gone
assert gone['ips-sim']['utime'] == sim_last + 2_000_000, (gone['ips-sim'], sim_last)
degraded = [a for a in alerts if a['kind'] == ALERT_PROCESS_DEGRADED]
assert any(a['subject'].startswith('ips-aoa@') and a['state'] == ALERT_RAISED for a in degraded), \
    degraded
assert not any(a['subject'].startswith('ips-zones@') for a in alerts), 'watched itself'
ids = {}
for a in alerts:  # RAISED then CLEARED under one id, ids never reused for another alert
    ids.setdefault(a['id'], []).append((a['kind'], a['subject'], a['state']))
assert all(len({(k, s) for k, s, _ in v}) == 1 and [st for _, _, st in v][0] == ALERT_RAISED
           for v in ids.values()), ids
zh = [h for h in hs if h['source'] == 'ips-zones']
assert zh and all(h['state'] in (0, 3) for h in zh), [(h['state'], h['last_error']) for h in zh]
assert zh[-1]['msgs_in'] > 1000 and zh[-1]['msgs_out'] > 0, zh[-1]
print(f"live: {len(alerts)} alerts ({len(silent)} tag silent, {len(gone)} gone, "
      f"{len(degraded)} degraded), ips-zones HEALTH OK in {len(zh)} reports")
PY
grep -q 'alert [0-9]*: T1: no pose on TRUTH for 2.0 s' "$WORK/zones.err" ||
  fail "ips-zones did not log the alert: $(cat "$WORK/zones.err")"

# --- 4. command line -----------------------------------------------------------------------------
"$BIN/ips-zones" --help | grep -q -- '--pose-channel' || fail "--help"
rc=0
"$BIN/ips-zones" --pose-channel 'A B' 2>"$WORK/err" || rc=$?
[ "$rc" -eq 2 ] || fail "a bad --pose-channel: status $rc (expected 2)"
grep -q "^ips-zones: error: --pose-channel: 'A B' is not a channel name" "$WORK/err" ||
  fail "a bad --pose-channel: $(cat "$WORK/err")"
echo "zones_lab_netns: OK"
