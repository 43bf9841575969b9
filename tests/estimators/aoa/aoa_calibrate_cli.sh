#!/usr/bin/env bash
# ips-aoa-calibrate on real files: aoa-hall-calibration (five tags at the hall's surveyed points,
# 60 s) simulated with known anchor biases, calibrated at degree 0 from the five --point's; the
# table, the written site's estimators.aoa.calibration block (each c0 = minus the bias minus the
# mean edge compression over the points, within 0.5 deg), the written site loading again; the
# default degree 1; --truth on the aoa-hall walk; the error paths (one line, status 2).
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"  # fail, ok, run, expect_error; counts failures
CAL="$BIN/ips-aoa-calibrate"

# The biases injected (azimuth, elevation) and the five points of Table 7.2 (z: the site's
# height_m of each tag, which the scenario sets to the surveyed z).
BIASES="A1: [2.5, -1.0], A2: [-4.0, 2.0], A3: [1.0, 0.5], A4: [-1.5, -3.0]"
POINTS=(--point T1=2.186,3.369 --point T2=3.884,3.599 --point T3=2.267,7.090
        --point T4=0.355,3.446 --point T5=2.060,0.831)
sed "s/^    bias_sigma_deg: 3.0$/    bias_sigma_deg: 3.0\n    anchor_bias_deg: {$BIASES}/" \
  "$ROOT/config/scenarios/aoa-hall-calibration.yaml" >"$WORK/biased.yaml"
grep -q "anchor_bias_deg" "$WORK/biased.yaml" || fail "could not make the biased scenario"
"$BIN/ips-sim" --scenario "$WORK/biased.yaml" --seed 4 --out "$WORK/cal.lcm" --log-level warn || exit 1

# check_offsets SITE TOL: the azimuth c0 of each anchor in SITE's calibration block against
# -bias - mean compression over the points (the simulator's theta + 0.0008 theta^2 - 0.000046
# theta^3, docs/scenarios/aoa-hall.md), and the elevation c0 (when written) against -bias.
check_offsets() {
  python3 - "$1" "$2" <<'PY'
import math, re, sys
text = open(sys.argv[1]).read()
tol = float(sys.argv[2])
anchors = {'A1': ((0.000, 0.000, 1.683), 60.73), 'A2': ((4.552, -0.119, 1.627), 119.27),
           'A3': ((-0.105, 8.126, 1.723), -60.73), 'A4': ((4.651, 8.103, 1.681), -119.27)}
bias = {'A1': (2.5, -1.0), 'A2': (-4.0, 2.0), 'A3': (1.0, 0.5), 'A4': (-1.5, -3.0)}
points = [(2.186, 3.369), (3.884, 3.599), (2.267, 7.090), (0.355, 3.446), (2.060, 0.831)]
worst = 0
for a, ((x, y, _), yaw) in anchors.items():
    comp = 0
    for px, py in points:
        th = yaw - math.degrees(math.atan2(py - y, px - x))
        th = (th + 180) % 360 - 180
        comp += 0.0008 * th**2 - 0.000046 * th**3
    want = {'azimuth': -bias[a][0] - comp / len(points), 'elevation': -bias[a][1]}
    block = re.search(r'\n\s+' + a + r':\n((?:\s+\w+: \{.*\}\n)+)', text)
    if not block:
        print(f'{a}: no calibration entry'); sys.exit(1)
    for angle, c0 in re.findall(r'(\w+): \{polynomial: \[([-0-9.e+]+)', block.group(1)):
        err = float(c0) - want[angle]
        print(f'{a} {angle} c0 {float(c0):+.3f} want {want[angle]:+.3f}', end='; ')
        worst = max(worst, abs(err))
print(f'worst {worst:.3f}')
sys.exit(0 if worst <= tol else 1)
PY
}

# 1. Degree 0 from the five points, azimuth and elevation, written to a site file.
if run 0 "$CAL" --log "$WORK/cal.lcm" "${POINTS[@]}" --degree 0 --elevation --out "$WORK/site.yaml"; then
  cat "$WORK/out"
  grep -Eq "^ips-aoa-calibrate: [0-9]+ BLE_AOA events read: [0-9]+ with a reference angle, [0-9]+ of them dropped as multipath duplicates$" \
    "$WORK/out" && ok "summary line" || fail "summary: $(head -1 "$WORK/out")"
  grep -Eq "^1 +T1 +2.186 +3.369 +1.528 +all +2[0-9]{3}$" "$WORK/out" &&
    grep -Eq "^5 +T5 +2.060 +0.831 +-0.009 +all +2[0-9]{3}$" "$WORK/out" &&
    ok "points: z from the site's tag heights, ~2500 events each" || fail "points table"
  for a in A1 A2 A3 A4; do
    grep -Eq "^$a +az +0 +5 +" "$WORK/out" && grep -Eq "^$a +el +0 +5 +" "$WORK/out" ||
      fail "$a: no degree-0 row with 5 reference angles"
  done
  grep -q "^wrote $WORK/site.yaml$" "$WORK/out" || fail "no 'wrote' line"
  head -1 "$WORK/site.yaml" | grep -q "^# Calibrated by ips-aoa-calibrate from .*cal.lcm: 4 anchors, 5 known points, degree 0, azimuth and elevation.$" &&
    ok "header comment" || fail "header: $(head -1 "$WORK/site.yaml")"
  if errs=$(check_offsets "$WORK/site.yaml" 0.5); then ok "offsets: $errs"; else fail "offsets: $errs"; fi
  grep -q "{id: A1, kind: ble_aoa, position: \[0.000, 0.000, 1.683\], orientation_deg: \[0, 0, 60.73\]}" "$WORK/site.yaml" &&
    ok "anchors unchanged" || fail "anchors changed"
fi

# The written site loads (--site) and its calibration block is recognised (replaced, noted).
if run 0 "$CAL" --log "$WORK/cal.lcm" --site "$WORK/site.yaml" "${POINTS[@]}"; then
  [ "$(grep -c "the input site's calibration is replaced" "$WORK/out")" -eq 4 ] &&
    ok "written site loads with 4 calibrated anchors" || fail "reload: $(tail -5 "$WORK/out")"
  grep -q "(no --out: nothing written)" "$WORK/out" || fail "no --out: no note"
  # The default degree 1: a slope near 1 (the edge compression's inverse, within 10 %).
  for a in A1 A2 A3 A4; do
    awk -v a="$a" '$1 == a && $2 == "az" { ok = ($3 == 1 && $12 > 0.95 && $12 < 1.10) } END { exit !ok }' "$WORK/out" ||
      fail "$a: degree 1 row: $(grep "^$a " "$WORK/out")"
  done
fi

# --out refuses an existing file, --force overwrites it; a window per point.
expect_error 2 "^ips-aoa-calibrate: error: --out: '.*site.yaml' exists \(--force overwrites it\)$" \
  "$CAL" --log "$WORK/cal.lcm" "${POINTS[@]}" --out "$WORK/site.yaml"
if run 0 "$CAL" --log "$WORK/cal.lcm" --point T1=2.186,3.369@0-30 --point T5=2.060,0.831,-0.009@30-60 \
  --out "$WORK/site.yaml" --force; then
  grep -Eq "^1 +T1 .* +0-30 +1[0-9]{3}$" "$WORK/out" && grep -Eq "^2 +T5 .* +30-60 +1[0-9]{3}$" "$WORK/out" &&
    ok "windows: about half the events each" || fail "windows: $(sed -n 3,5p "$WORK/out")"
  grep -q "^skipped: [0-9]* events from tags without a --point" "$WORK/out" &&
    grep -q "^skipped: [0-9]* events outside their tag's point windows" "$WORK/out" &&
    ok "skipped events counted" || fail "skipped counts: $(grep skipped "$WORK/out")"
  # Two points: at A3 their azimuths are 3.55 and 12.74 deg, too close for a slope.
  grep -q "^note: A3 az: degree 0 instead of 1: degree 1 needs reference angles spanning 10.0 deg, 9.2 here$" "$WORK/out" &&
    grep -Eq "^A1 +az +1 +2 " "$WORK/out" && grep -Eq "^A3 +az +0 +2 " "$WORK/out" &&
    ok "two points: A1 degree 1, A3 degree 0 with the reason" || fail "fallback: $(grep -E "note|^A" "$WORK/out")"
fi

# --truth: the aoa-hall walk with TRUTH as the reference.
"$BIN/ips-sim" --scenario aoa-hall --seed 4 --duration 30 --out "$WORK/walk.lcm" --log-level warn || exit 1
if run 0 "$CAL" --log "$WORK/walk.lcm" --truth; then
  grep -Eq "^reference: TRUTH \([0-9]+ poses\)$" "$WORK/out" && grep -Eq "^A4 +az +1 +" "$WORK/out" &&
    ok "--truth on the walk" || fail "--truth: $(cat "$WORK/out")"
fi

# Errors.
"$BIN/ips-sim" --scenario walk-square --duration 2 --out "$WORK/noaoa.lcm" --log-level warn || exit 1
echo "not a log" >"$WORK/text.txt"
expect_error 2 "^ips-aoa-calibrate: error: give the reference: --point" "$CAL" --log "$WORK/cal.lcm"
expect_error 2 "^ips-aoa-calibrate: error: --log is required" "$CAL" "${POINTS[@]}"
expect_error 2 "^ips-aoa-calibrate: error: --point: expected TAG=X,Y\[,Z\]\[@START-END\] \(m, s\), got 'T1=1'$" \
  "$CAL" --log "$WORK/cal.lcm" --point T1=1
expect_error 2 "^ips-aoa-calibrate: error: --point: expected .* got 'T1=1,2@5'$" \
  "$CAL" --log "$WORK/cal.lcm" --point T1=1,2@5
expect_error 2 "^ips-aoa-calibrate: error: --point: two points of tag T1 with overlapping windows" \
  "$CAL" --log "$WORK/cal.lcm" --point T1=1,2@0-30 --point T1=2,2@20-40
expect_error 2 "^ips-aoa-calibrate: error: --point: point of T1: its window must have START <= END$" \
  "$CAL" --log "$WORK/cal.lcm" --point T1=1,2@30-20
expect_error 2 "^ips-aoa-calibrate: error: unknown tag 'T9': not in the site's tags and no BLE_AOA event from it$" \
  "$CAL" --log "$WORK/cal.lcm" --point T9=1,2
expect_error 2 "^ips-aoa-calibrate: error: point T1 at \(2.186, 3.369, 1.528\) between 100 and 200 s: no BLE_AOA event of T1 from a site anchor in its window \([0-9]+ events of T1 in all\)$" \
  "$CAL" --log "$WORK/cal.lcm" --point T1=2.186,3.369@100-200
expect_error 2 "^ips-aoa-calibrate: error: no BLE_AOA events in .*noaoa.lcm \(channel BLE_AOA\)$" \
  "$CAL" --log "$WORK/noaoa.lcm" --truth
expect_error 2 "^ips-aoa-calibrate: error: --degree: expected 0, 1, 2 or 3$" "$CAL" --log "$WORK/cal.lcm" --truth --degree 4
expect_error 2 "^ips-aoa-calibrate: error: --min-samples: expected at least 1$" "$CAL" --log "$WORK/cal.lcm" --truth --min-samples 0
expect_error 2 "^ips-aoa-calibrate: error: no anchor could be fitted \(A1: 5[0-9]{2} samples, fewer than the 100000 required; " \
  "$CAL" --log "$WORK/cal.lcm" --point T1=2.186,3.369 --min-samples 100000
expect_error 2 "^ips-aoa-calibrate: error: cannot read log '.*missing.lcm'" "$CAL" --log "$WORK/missing.lcm" --truth
expect_error 2 "^ips-aoa-calibrate: error: '.*text.txt' is not an LCM log" "$CAL" --log "$WORK/text.txt" --truth
expect_error 2 "^ips-aoa-calibrate: error: --out: no directory '.*/nodir'$" \
  "$CAL" --log "$WORK/cal.lcm" --truth --out "$WORK/nodir/site.yaml"
if run 0 "$CAL" --help; then
  grep -q -- "--point TAG=X,Y\[,Z\]\[@START-END\]" "$WORK/out" && grep -q -- "--truth" "$WORK/out" &&
    grep -q -- "--elevation" "$WORK/out" && ok "--help" || fail "--help lacks options"
fi

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
