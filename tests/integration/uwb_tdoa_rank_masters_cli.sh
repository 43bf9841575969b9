#!/usr/bin/env bash
# ips-uwb-tdoa on the command line, no network needed:
#  1. rank-masters (004 §3's best-master study) on real log files: six 60 s logs of
#     tdoa-hall-static made by ips-sim, one per sync master (the scenario file with `master:`
#     changed by sed). The table has one row per log, sorted by variance, each with its log's
#     master; a master that syncs all six anchors (A1 or A4) ranks first, and both rank above the
#     masters that sync only four (A3, A5). Mean distances from the known point are small.
#  2. Bad command lines and files: one error line, status 2 (1 when no log has an estimate).
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"  # fail, expect; counts failures

# --- 1: the ranking ------------------------------------------------------------------------
logs=()
for m in A1 A2 A3 A4 A5 A6; do
  sed "s/^    master: A4$/    master: $m/" "$ROOT/config/scenarios/tdoa-hall-static.yaml" >"$WORK/static-$m.yaml"
  grep -q "^    master: $m$" "$WORK/static-$m.yaml" || fail "sed did not set master $m"
  "$BIN/ips-sim" --scenario "$WORK/static-$m.yaml" --seed 3 --duration 60 --out "$WORK/$m.lcm" \
    --log-level warn || fail "ips-sim for master $m"
  logs+=("$WORK/$m.lcm")
done
status=0
"$BIN/ips-uwb-tdoa" rank-masters "${logs[@]}" --truth 3.0,2.0 --skip 5 --log-level warn \
  >"$WORK/table" 2>"$WORK/err" || status=$?
cat "$WORK/table"
[ "$status" -eq 0 ] || fail "rank-masters exited with $status: $(cat "$WORK/err")"
[ ! -s "$WORK/err" ] || fail "rank-masters wrote to stderr: $(cat "$WORK/err")"
head -1 "$WORK/table" | grep -q '^rank  *master  *tag  *estimates  *mean_dist_m  *std_m  *variance_m2  *log$' ||
  fail "no table header"
rows=$(awk '$1 ~ /^[0-9]+$/' "$WORK/table")
[ "$(echo "$rows" | wc -l)" -eq 6 ] || fail "expected 6 rows"
# Each row's master is the one its log was made with; tag T1; over 450 estimates (10 Hz from 5 s
# after the first); mean distance from the point under 0.15 m.
echo "$rows" | awk '{ split($8, p, "/"); f = p[length(p)]; sub(/\.lcm$/, "", f)
  if ($2 != f || $3 != "T1" || $4 < 450 || $5 >= 0.15) { print "bad row: " $0; bad = 1 } }
  END { exit bad }' || fail "rows do not match their logs"
echo "$rows" | awk 'NR > 1 && $7 < prev { bad = 1 } { prev = $7 } END { exit bad }' ||
  fail "rows not sorted by variance"
place() { echo "$rows" | awk -v m="$1" '$2 == m { print $1 }'; }
first=$(echo "$rows" | awk 'NR == 1 { print $2 }')
[ "$first" = A1 ] || [ "$first" = A4 ] || fail "best master $first (expected A1 or A4)"
for all in A1 A4; do
  for four in A3 A5; do
    [ "$(place $all)" -lt "$(place $four)" ] || fail "$all ranked below $four"
  done
done
# Without --truth the spread is around each log's mean: the same rows, smaller mean distances.
"$BIN/ips-uwb-tdoa" rank-masters "${logs[@]}" --skip 5 >"$WORK/table2" 2>"$WORK/err" ||
  fail "rank-masters without --truth: $(cat "$WORK/err")"
[ "$(awk '$1 ~ /^[0-9]+$/' "$WORK/table2" | wc -l)" -eq 6 ] || fail "without --truth: expected 6 rows"
grep -q 'from the mean of each log' "$WORK/table2" || fail "without --truth: no note of the centre"
[ $failures -eq 0 ] && echo "ok: rank-masters ranks six simulated logs"

# --- 2: bad input ---------------------------------------------------------------------------
# expect STATUS PATTERN CMD... (cli_check_lib.sh): status, exactly one stderr line matching PATTERN.
printf 'not a log\n' >"$WORK/text.lcm"
cat >"$WORK/bad-params.yaml" <<'YAML'
anchors:
  - {id: A1, kind: uwb_tdoa, position: [0, 0, 2.5]}
estimators:
  uwb_tdoa:
    reference: A7
YAML
expect 2 "^ips-uwb-tdoa: error: cannot read log '.*missing.lcm'" \
  "$BIN/ips-uwb-tdoa" rank-masters "$WORK/missing.lcm"
expect 2 "^ips-uwb-tdoa: error: .*not an LCM log" "$BIN/ips-uwb-tdoa" rank-masters "$WORK/text.lcm"
expect 2 "^ips-uwb-tdoa: error: --truth: expected X,Y or X,Y,Z" \
  "$BIN/ips-uwb-tdoa" rank-masters "$WORK/A1.lcm" --truth 1,nan
expect 2 "^ips-uwb-tdoa: error: .*LOG" "$BIN/ips-uwb-tdoa" rank-masters
expect 2 "^ips-uwb-tdoa: error: --lcm-url does not apply" \
  "$BIN/ips-uwb-tdoa" rank-masters "$WORK/A1.lcm" --lcm-url memq://
expect 1 "^ips-uwb-tdoa: error: no estimate of tag 'T9' in any log" \
  "$BIN/ips-uwb-tdoa" rank-masters "$WORK/A1.lcm" --tag T9
expect 2 "^ips-uwb-tdoa: error: .*bad-params.yaml:5: estimators.uwb_tdoa.reference: expected nearest, master or an enabled uwb_tdoa anchor" \
  "$BIN/ips-uwb-tdoa" rank-masters "$WORK/A1.lcm" --site "$WORK/bad-params.yaml"
expect 2 "^ips-uwb-tdoa: error: .*bad-params.yaml:5: estimators.uwb_tdoa.reference" \
  "$BIN/ips-uwb-tdoa" --lcm-url memq:// --site "$WORK/bad-params.yaml"
expect 2 "^ips-uwb-tdoa: error: .*--bogus" "$BIN/ips-uwb-tdoa" --bogus
expect 2 "^ips-uwb-tdoa: error: --channel: unknown kind 'POSE_TDAO'" \
  "$BIN/ips-uwb-tdoa" --channel POSE_TDAO=X
"$BIN/ips-uwb-tdoa" --help >/dev/null || fail "--help"
"$BIN/ips-uwb-tdoa" rank-masters --help >/dev/null || fail "rank-masters --help"

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
