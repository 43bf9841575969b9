#!/usr/bin/env bash
# The real excerpts of tests/data/real through the documented command lines of
# docs/real-data.md (scripts/realdata.d/steps-oxford.sh, foot-openshoe.sh):
#  - steps-oxford (25 s of Samsung_Jamie_Hard_InHand_1, accelerometer only, about 100 Hz):
#    2500 IMU messages; ips-pdr counts steps from the accelerometer alone: within +-50 % of the
#    trace's own cadence (265 steps in 145 s: 45.7 in these 25 s), every STEP with heading_known
#    false and heading_rad NaN, no POSE_PDR; ips-replay's summary says why (a warning naming the
#    device without a gyroscope).
#  - foot-openshoe (8 s at 820 Hz: 2 s standing, then walking): 6560 IMU messages; ips-ins aligns
#    in the first second (822 samples) and then gives a pose per 0.1 s: 70 poses, a path of about
#    8.7 m (no truth: bounds 5 to 12 m, the walker's 6 s at 0.8 to 2 m/s).
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
cd "$tmp"
printf 'name: steps-oxford\nanchors: []\n' >site.yaml
printf 'name: foot-openshoe\nanchors: []\ntags:\n  - {id: foot1, start_position: [0, 0, 0], start_heading_deg: 0}\n' >foot-site.yaml

"$BIN/ips-phone-imu" --file "$ROOT/tests/data/real/steps-oxford/Samsung_Jamie_Hard_InHand_1-accelerometer-25s.csv" \
  --columns t,-,ax,ay,az --time-unit ns --out steps.lcm 2>steps.err || fail "steps import: $(cat steps.err)"
grep -qF "2500 rows read, 2500 messages written to steps.lcm, 0 rows rejected" steps.err ||
  fail "steps import: $(cat steps.err)"
"$BIN/ips-replay" steps.lcm --only pdr --site site.yaml --out steps-replay.lcm 2>steps-replay.err ||
  fail "steps replay: $(cat steps-replay.err)"
grep -qE ' warning ips-replay: pdr: no gyroscope on .+: steps only, heading unknown \(STEP heading_known false\), no POSE_PDR' \
  steps-replay.err || fail "steps replay does not say the heading is unknown: $(cat steps-replay.err)"
grep -qE ' info ips-replay: pdr: [0-9]+ steps \([0-9]+ counted from the walk.s cadence\)$' steps-replay.err ||
  fail "steps replay does not account for the steps: $(cat steps-replay.err)"
"$BIN/ips-export" steps-replay.lcm --channels 'STEP|POSE_PDR' --format csv --out steps-x >/dev/null 2>&1
[ ! -e steps-x/POSE_PDR.csv ] || fail "steps: POSE_PDR without a heading"
python3 - steps-x/STEP.csv <<'PY' || fail "steps: the STEP messages"
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert 23 <= len(rows) <= 69, f'{len(rows)} steps in 25 s (expected 23 to 69)'
assert all(r['heading_known'] in ('0', 'false') and math.isnan(float(r['heading_rad'])) for r in rows), rows[0]
print(f'ok: steps-oxford excerpt: {len(rows)} steps in 25 s (cadence of the trace: 45.7), '
      'heading unknown in every STEP')
PY

zcat "$ROOT/tests/data/real/foot-openshoe/OpenShoeDataSet-8s.txt.gz" >foot.txt
"$BIN/ips-phone-imu" --file foot.txt --columns ax,ay,az,gx,gy,gz --rate 820 --device-id foot1 \
  --out foot.lcm 2>foot.err || fail "foot import: $(cat foot.err)"
grep -qF "6560 rows read, 6560 messages written to foot.lcm, 0 rows rejected" foot.err ||
  fail "foot import: $(cat foot.err)"
"$BIN/ips-replay" foot.lcm --only ins --site foot-site.yaml --out foot-replay.lcm 2>foot-replay.err ||
  fail "foot replay: $(cat foot-replay.err)"
"$BIN/ips-export" foot-replay.lcm --channels POSE_INS --format csv --out foot-x >/dev/null 2>&1
python3 - foot-x/POSE_INS.csv <<'PY' || fail "foot: the track"
import csv, math, sys
p = [(float(r['position_x_m']), float(r['position_y_m'])) for r in csv.DictReader(open(sys.argv[1]))]
length = sum(math.dist(a, b) for a, b in zip(p, p[1:]))
assert 60 <= len(p) <= 80, len(p)
assert 5 <= length <= 12, length
print('ok: foot-openshoe excerpt: %d POSE_INS, path %.2f m, %.2f m from the start'
      % (len(p), length, math.dist(p[0], p[-1])))
PY
