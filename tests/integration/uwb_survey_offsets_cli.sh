#!/usr/bin/env bash
# ips-uwb-survey --offsets on real files: the lab scenario with every device (tag and anchors)
# delayed by 0.05 to 0.15 m (sensors.uwb_twr.device_delay_min_m / max_m), 60 s, anchor pairs at
# the lab's 1 Hz; the table, the site written with estimators.uwb_twr.range_offsets_m (one key
# per anchor: its delay plus the tags', taken as the anchors' mean), read back with --site (the
# site_m column), the other keys of the site kept; and the error paths: one line, status 2 for
# usage, 1 when the ranges cannot determine the delays. The delays against the simulator's own,
# and ips-uwb-twr from the seeded site: the GoogleTest AnchorDelaysSim.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"  # fail, ok, run, expect_error; counts failures
SURVEY="$BIN/ips-uwb-survey"

# delayed EXTRA OUT: the lab scenario with device delays 0.05-0.15 m and EXTRA uwb_twr lines.
delayed() {
  sed "s/^    anchor_pairs_rate_hz: 1 .*/&\n    device_delay_min_m: 0.05\n    device_delay_max_m: 0.15$1/" \
    "$ROOT/config/scenarios/lab.yaml" >"$2"
  grep -q "device_delay_max_m: 0.15" "$2" || fail "could not make the delayed scenario"
}
delayed "" "$WORK/delayed.yaml"
"$BIN/ips-sim" --scenario "$WORK/delayed.yaml" --seed 1 --duration 60 --out "$WORK/lab.lcm" \
  --log-level warn || exit 1

# 1. The delays, written to a site file.
if run 0 "$SURVEY" --log "$WORK/lab.lcm" --offsets --out "$WORK/seeded.yaml"; then
  cat "$WORK/out"
  grep -q "360 between anchors" "$WORK/out" && ok "360 anchor-pair ranges (6 pairs, 1 Hz, 60 s)" ||
    fail "pair range count: $(head -1 "$WORK/out")"
  # pair ranges range_m dist_m offset_m resid_m: offsets d_a + d_b in [0.1, 0.3] give or take noise
  for pair in A1-A2 A1-A3 A1-A4 A2-A3 A2-A4 A3-A4; do
    awk -v p="$pair" '$1 == p { ok = ($2 == 60 && $5 >= 0.07 && $5 <= 0.33 && $6 >= -0.05 &&
        $6 <= 0.05) } END { exit !ok }' "$WORK/out" || fail "pair $pair: $(grep "^$pair " "$WORK/out")"
  done
  # anchor delay_m sigma_m pairs seed_m seed_sig site_m
  for a in A1 A2 A3 A4; do
    awk -v a="$a" '$1 == a && NF == 7 { ok = ($2 >= 0.02 && $2 <= 0.18 && $3 > 0 && $3 < 0.03 &&
        $4 == 3 && $7 == "-") } END { exit !ok }' "$WORK/out" || fail "anchor $a: $(grep "^$a " "$WORK/out")"
  done
  grep -Eq "^6 pairs used, redundancy 2, residual RMS 0\.0[0-9]{2} m" "$WORK/out" &&
    ok "$(grep '^6 pairs used' "$WORK/out")" || fail "summary line"
  grep -Eq "^seed_m = delay_m \+ 0\.[01][0-9]{2} m, the tags' delay taken as the anchors' mean" \
    "$WORK/out" && ok "tag delay assumption stated" || fail "no tag delay line"
  grep -q "^wrote $WORK/seeded.yaml (4 offsets)$" "$WORK/out" || fail "no 'wrote' line"
  head -1 "$WORK/seeded.yaml" | grep -q "^# Range offsets seeded by ips-uwb-survey --offsets from .*lab.lcm" &&
    ok "header comment" || fail "header: $(head -1 "$WORK/seeded.yaml")"
  # The written offsets are the table's seed_m, under estimators.uwb_twr.range_offsets_m.
  for a in A1 A2 A3 A4; do
    want=$(awk -v a="$a" '$1 == a && NF == 7 { print $5 }' "$WORK/out")
    awk -v a="$a" -v w="$want" 'BEGIN { ok = 0 } /^    range_offsets_m:$/ { in_map = 1; next }
        in_map && $1 == a ":" { ok = (sprintf("%.3f", $2) == w) } END { exit !ok }' "$WORK/seeded.yaml" &&
      ok "$a: written $(awk -v a="$a" '$1 == a ":" { print $2 }' "$WORK/seeded.yaml") (table $want)" ||
      fail "$a: written offset is not the table's $want"
  done
  grep -q "{id: A1, kind: uwb, position: \[0.0, 0.0, 2.4\]}" "$WORK/seeded.yaml" &&
    grep -q "{id: B2, kind: ble_aoa, position: \[10.0, 4.0, 2.2\], orientation_deg: \[0, 0, 180\]}" "$WORK/seeded.yaml" &&
    grep -q "{id: T1, height_m: 1.2, start_position: \[2.0, 1.5\], start_heading_deg: 0}" "$WORK/seeded.yaml" && ok "anchors and tags unchanged" ||
    fail "anchors or tags changed"
fi

# 2. The written site read back: its offsets in the site_m column, equal to the new seed.
if run 0 "$SURVEY" --log "$WORK/lab.lcm" --offsets --site "$WORK/seeded.yaml"; then
  for a in A1 A2 A3 A4; do
    awk -v a="$a" '$1 == a && NF == 7 { ok = ($7 == $5) } END { exit !ok }' "$WORK/out" ||
      fail "$a: site_m: $(grep "^$a " "$WORK/out")"
  done
  ok "written site loads; site_m = seed_m"
  grep -q "(no --out: nothing written)" "$WORK/out" || fail "no --out: no note"
fi

# 3. The other keys of the input site kept; a pair key of an anchor written is dropped (it would
#    override the anchor's offset in the trackers), one of another tag-anchor key kept.
{
  cat "$ROOT/config/sites/lab.yaml"
  printf '    learn_bias: false\n    range_offsets_m: {T1/A2: 0.5, T9/B7: 0.25}\n'
} >"$WORK/with-keys.yaml"
cp "$ROOT/config/sites/lab-plan.svg" "$WORK/"  # the floor plan, beside the site file
if run 0 "$SURVEY" --log "$WORK/lab.lcm" --offsets --site "$WORK/with-keys.yaml" --out "$WORK/kept.yaml"; then
  grep -q "^    range_sigma_m: 0.10\?$" "$WORK/kept.yaml" && grep -q "^    learn_bias: false$" "$WORK/kept.yaml" &&
    ok "other uwb_twr keys kept" || fail "uwb_twr keys: $(sed -n '/^estimators:/,$p' "$WORK/kept.yaml")"
  grep -q "T1/A2" "$WORK/kept.yaml" && fail "T1/A2 kept (it would override A2)" || ok "T1/A2 dropped"
  grep -q "T9/B7: 0.25" "$WORK/kept.yaml" && ok "T9/B7 kept" || fail "T9/B7 lost"
fi

# 4. Errors.
expect_error 2 "^ips-uwb-survey: error: --offsets uses the site's anchor positions: --order, --known-point and --known-window do not apply$" \
  "$SURVEY" --log "$WORK/lab.lcm" --offsets --order A1,A2,A3
expect_error 2 "^ips-uwb-survey: error: --out: '.*seeded.yaml' exists \(--force overwrites it\)$" \
  "$SURVEY" --log "$WORK/lab.lcm" --offsets --out "$WORK/seeded.yaml"
# Beyond 11 m the diagonals (12.8 m) are not ranged: the four sides close no triangle.
delayed "\n    max_range_m: 11" "$WORK/sides.yaml"
"$BIN/ips-sim" --scenario "$WORK/sides.yaml" --seed 1 --duration 20 --out "$WORK/sides.lcm" \
  --log-level warn || exit 1
expect_error 1 "^ips-uwb-survey: error: offsets failed: delays not determined: A1, A2, A3, A4 \(their pairs A1-A2, A1-A4, A2-A3, A3-A4 close no odd cycle such as a triangle, so \+c and -c alternately fit alike\)$" \
  "$SURVEY" --log "$WORK/sides.lcm" --offsets --out "$WORK/never.yaml"
[ ! -e "$WORK/never.yaml" ] && ok "failed offsets write nothing" || fail "failed offsets wrote --out"
"$BIN/ips-sim" --scenario "$WORK/delayed.yaml" --seed 1 --duration 5 --out "$WORK/short.lcm" \
  --log-level warn || exit 1
expect_error 1 "^ips-uwb-survey: error: offsets failed: delays not determined: A1, A2, A3, A4 \(no pair used\); refused pairs: A1-A2 \(5 ranges, fewer than the 10 required\)" \
  "$SURVEY" --log "$WORK/short.lcm" --offsets
if run 0 "$SURVEY" --log "$WORK/short.lcm" --offsets --min-samples 5; then ok "--min-samples 5 on a 5 s log"; fi
if run 0 "$SURVEY" --help; then
  grep -q -- "--offsets" "$WORK/out" && ok "--help has --offsets" || fail "--help lacks --offsets"
fi

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
