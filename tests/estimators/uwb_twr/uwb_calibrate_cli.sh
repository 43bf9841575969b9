#!/usr/bin/env bash
# ips-uwb-calibrate on real files: the lab scenario with every tag-anchor pair offset by 0.1 to
# 0.3 m (sensors.uwb_twr.pair_offset_min_m / max_m), 30 s; the table, the site written with
# estimators.uwb_twr.range_offsets_m (anchor keys: one tag), read back with --site (its offsets
# bring each pair's residual median within 0.02 m of zero), --scale, the refusals (--force) and
# the error paths (one line, status 2). The offsets against the simulator's own: the GoogleTest
# RangeCalibrationSim.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"  # fail, ok, run, expect_error; counts failures
CAL="$BIN/ips-uwb-calibrate"

# biased MIN MAX OUT: the lab scenario with pair offsets MIN..MAX m.
biased() {
  sed "s/^    anchor_pairs_rate_hz: 1 .*/&\n    pair_offset_min_m: $1\n    pair_offset_max_m: $2/" \
    "$ROOT/config/scenarios/lab.yaml" >"$3"
  grep -q "pair_offset_max_m: $2" "$3" || fail "could not make the biased scenario"
}
biased 0.1 0.3 "$WORK/biased.yaml"
"$BIN/ips-sim" --scenario "$WORK/biased.yaml" --seed 3 --duration 30 --out "$WORK/cal.lcm" \
  --log-level warn || exit 1

# 1. The fit, written to a site file.
if run 0 "$CAL" "$WORK/cal.lcm" --scale --out "$WORK/site.yaml"; then
  cat "$WORK/out"
  grep -Eq "^ips-uwb-calibrate: 1380 UWB_RANGE read, 1501 TRUTH poses on TRUTH; site from the log's SITE$" \
    "$WORK/out" && ok "summary line" || fail "summary: $(head -1 "$WORK/out")"
  grep -q "^skipped: 180 ranges between two anchors$" "$WORK/out" && ok "anchor pairs skipped" ||
    fail "anchor pairs: $(grep skipped "$WORK/out")"
  # tag anchor ranges n offset std rms_raw rms_cal med_cal med_site scale line_b
  for a in A1 A2 A3 A4; do
    awk -v a="$a" '$1 == "T1" && $2 == a { ok = ($4 == 300 && $5 >= 0.08 && $5 <= 0.32 &&
        $8 < $7 && ($9 + 0) == 0 && $10 == "-" && $11 != "" && $12 != "") } END { exit !ok }' \
      "$WORK/out" || fail "$a row: $(grep "^T1 *$a " "$WORK/out")"
  done
  # The radios have no scale: no fitted scale is 3 standard errors off 0, none is written.
  grep -q "^scales: used for none; 0 for T1/A1 T1/A2 T1/A3 T1/A4$" "$WORK/out" &&
    ok "no scale written" || fail "scales: $(grep '^scales:' "$WORK/out")"
  grep -q "range_scales" "$WORK/site.yaml" && fail "range_scales written"
  grep -q "^wrote $WORK/site.yaml (4 offsets)$" "$WORK/out" || fail "no 'wrote' line"
  head -1 "$WORK/site.yaml" | grep -q "^# Range offsets by ips-uwb-calibrate from .*cal.lcm: 4 pairs" &&
    ok "header comment" || fail "header: $(head -1 "$WORK/site.yaml")"
  # The written offsets are the table's, under estimators.uwb_twr.range_offsets_m.
  grep -Eq "^estimators:$" "$WORK/site.yaml" && grep -Eq "^  uwb_twr:$" "$WORK/site.yaml" ||
    fail "no estimators.uwb_twr in the written site"
  for a in A1 A2 A3 A4; do
    want=$(awk -v a="$a" '$1 == "T1" && $2 == a { printf "%.4f", $5 }' "$WORK/out")
    awk -v a="$a" -v w="$want" 'BEGIN { ok = 0 } /^    range_offsets_m:$/ { in_map = 1; next }
        in_map && $1 == a ":" { ok = ($2 == w) } END { exit !ok }' "$WORK/site.yaml" ||
      fail "$a: written offset is not the table's $want"
  done
  grep -q "{id: A1, kind: uwb, position: \[0.0, 0.0, 2.4\]}" "$WORK/site.yaml" &&
    ok "anchors unchanged" || fail "anchors changed"
fi

# 2. The written site read back: each pair's residual median with its offsets within 0.02 m.
if run 0 "$CAL" "$WORK/cal.lcm" --site "$WORK/site.yaml"; then
  grep -q "site from $WORK/site.yaml$" "$WORK/out" || fail "site not from --site"
  for a in A1 A2 A3 A4; do
    awk -v a="$a" '$1 == "T1" && $2 == a { m = $10 + 0; ok = ($10 != "-" && m <= 0.02 && m >= -0.02) }
        END { exit !ok }' "$WORK/out" && ok "$a: median with the written offset $(awk -v a="$a" '$1 == "T1" && $2 == a { print $10 }' "$WORK/out")" ||
      fail "$a: med_site: $(grep "^T1 *$a " "$WORK/out")"
  done
  grep -q "(no --out: nothing written)" "$WORK/out" || fail "no --out: no note"
fi

# 3. Refusals: too few ranges (1 s: 10 per pair), offsets beyond 1 m; --force writes them.
"$BIN/ips-sim" --scenario "$WORK/biased.yaml" --seed 3 --duration 1 --out "$WORK/short.lcm" \
  --log-level warn || exit 1
expect_error 2 "^ips-uwb-calibrate: error: refused \(--force writes them\), nothing written: T1/A1: 10 ranges with truth, fewer than the 20 required; " \
  "$CAL" "$WORK/short.lcm" --out "$WORK/short.yaml"
[ -e "$WORK/short.yaml" ] && fail "a refused fit wrote a site"
run 0 "$CAL" "$WORK/short.lcm" --force --out "$WORK/short.yaml" && ok "--force writes the short fit"
biased 1.2 1.4 "$WORK/far.yaml"
"$BIN/ips-sim" --scenario "$WORK/far.yaml" --seed 3 --duration 5 --out "$WORK/far.lcm" \
  --log-level warn || exit 1
expect_error 2 "^ips-uwb-calibrate: error: refused .*T1/A1: offset \+1\.[0-9]{3} m outside \[-1, 1\] m" \
  "$CAL" "$WORK/far.lcm"

# 4. Errors.
"$BIN/ips-sim" --scenario aoa-hall --duration 2 --out "$WORK/nouwb.lcm" --log-level warn || exit 1
echo "not a log" >"$WORK/text.txt"
expect_error 2 "^ips-uwb-calibrate: error: LOG is required" "$CAL"
expect_error 2 "^ips-uwb-calibrate: error: --out: '.*site.yaml' exists \(--force overwrites it\)$" \
  "$CAL" "$WORK/cal.lcm" --out "$WORK/site.yaml"
expect_error 2 "^ips-uwb-calibrate: error: --out: no directory '.*/nodir'$" \
  "$CAL" "$WORK/cal.lcm" --out "$WORK/nodir/site.yaml"
expect_error 2 "^ips-uwb-calibrate: error: no truth: no pose_t on channel MOCAP in .*cal.lcm \(--truth CHANNEL\)$" \
  "$CAL" "$WORK/cal.lcm" --truth MOCAP
expect_error 2 "^ips-uwb-calibrate: error: no UWB_RANGE messages in .*nouwb.lcm \(channel UWB_RANGE\)$" \
  "$CAL" "$WORK/nouwb.lcm"
expect_error 2 "^ips-uwb-calibrate: error: cannot read log '.*missing.lcm'" "$CAL" "$WORK/missing.lcm"
expect_error 2 "^ips-uwb-calibrate: error: '.*text.txt' is not an LCM log" "$CAL" "$WORK/text.txt"
if run 0 "$CAL" --help; then
  grep -q -- "--truth CHANNEL" "$WORK/out" && grep -q -- "--scale" "$WORK/out" &&
    grep -q -- "--out SITE_OUT" "$WORK/out" && ok "--help" || fail "--help lacks options"
fi

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
