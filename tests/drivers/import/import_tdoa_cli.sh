#!/usr/bin/env bash
# ips-import tdoa on small files: the UTIL dataset's flight-CSV layout (t_tdoa, idA, idB,
# tdoa_meas beside an IMU's columns; tests/data/tdoa/util-style.csv, synthetic values) read by its
# header with the other sensor's rows skipped; a headerless file by --columns with a sigma column;
# rejected rows counted with their line; nothing silent: no tag, no difference column and garbage
# exit 1 with one error line. The log is read back by an independent reader (lcm_log.py).
set -uo pipefail
BIN=$(cd "$1" && pwd)
SRC=$(cd "$2" && pwd)
export PYTHONPATH="$SRC/tests/integration"  # lcm_log.py
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}
ok() { echo "ok: $*"; }
IMPORT="$BIN/ips-import"

run() {
  local want=$1 status=0
  shift
  timeout 60 "$@" >"$WORK/out" 2>"$WORK/err" || status=$?
  if [ "$status" -ne "$want" ]; then
    fail "$* -> status $status (want $want)"
    sed 's/^/  stderr: /' "$WORK/err" | head -10
    return 1
  fi
}

# "CHANNEL TIMESTAMP" per event of a log.
events() {
  python3 - "$1" <<'PY'
import sys, lcm_log
evs, n, size = lcm_log.events(sys.argv[1])
assert n == size, f"{n} of {size} bytes read"
for ch, ts, _ in evs:
    print(ch, ts)
PY
}

if run 0 "$IMPORT" tdoa --help; then
  grep -q -- "--columns" "$WORK/out" && grep -q "UTIL" "$WORK/out" && grep -q "t_tdoa, idA, idB" "$WORK/out" &&
    ok "tdoa --help names the columns and the UTIL layout" || fail "tdoa --help: $(head -3 "$WORK/out")"
fi
if run 0 "$IMPORT" --help; then
  grep -q "^ *tdoa " "$WORK/out" && ok "--help lists tdoa" || fail "--help does not list tdoa"
fi

# 1. The UTIL layout by its header: 12 differences, 4 IMU rows skipped, 2 rows rejected.
if run 0 "$IMPORT" tdoa "$SRC/tests/data/tdoa/util-style.csv" --tag T1 \
  --file-start 2026-01-01T00:00:00Z --out "$WORK/u.lcm"; then
  grep -q "util-style.csv: 12 rows, 12 differences, 2 rejected (first: line 18: anchor_a and anchor_b are the same anchor '2'); columns t,a,b,diff; time s" "$WORK/err" &&
    ok "UTIL layout: counts, the first rejected row and its line" || fail "summary: $(cat "$WORK/err")"
  grep -q "anchors 0 1 2 3; 4 rows without a difference (other sensors) skipped" "$WORK/err" &&
    ok "UTIL layout: the IMU rows skipped, counted" || fail "skipped line: $(cat "$WORK/err")"
  n=$(events "$WORK/u.lcm" | grep -c "^UWB_TDOA ")
  [ "$n" -eq 12 ] && ok "12 UWB_TDOA events in the log" || fail "$n UWB_TDOA events"
  first=$(events "$WORK/u.lcm" | head -1 | cut -d' ' -f2)
  [ "$first" = "1767225600000000" ] && ok "--file-start places the first row" || fail "first utime $first"
fi

# 2. Headerless, epoch times, --columns with sigma and the tag in the rows; a bad sigma rejected.
printf '%s\n' "1767225600.00,T7,A1,A2,0.512,0.05" "1767225600.01,T7,A2,A3,-0.250,0.05" \
  "1767225600.02,T7,A3,A4,0.100,-1" "1767225600.03,T7,A4,A1,-0.360," >"$WORK/plain.csv"
if run 0 "$IMPORT" tdoa "$WORK/plain.csv" --columns t,tag,a,b,diff,sigma --out "$WORK/p.lcm"; then
  grep -q "plain.csv: 3 rows, 3 differences, 1 rejected (first: line 3: sigma '-1' is not a number in (0, 100\] m)" "$WORK/err" &&
    ok "--columns t,tag,a,b,diff,sigma: counts and the bad sigma's line" || fail "summary: $(cat "$WORK/err")"
  [ "$(events "$WORK/p.lcm" | grep -c '^UWB_TDOA ')" -eq 3 ] && ok "3 differences written" ||
    fail "events: $(events "$WORK/p.lcm")"
fi
# --channel renames.
if run 0 "$IMPORT" tdoa "$WORK/plain.csv" --columns t,tag,a,b,diff,sigma --channel LPS_TDOA --out "$WORK/c.lcm"; then
  [ "$(events "$WORK/c.lcm" | grep -c '^LPS_TDOA ')" -eq 3 ] && ok "--channel LPS_TDOA" || fail "--channel"
fi

# 3. Nothing silent.
if run 1 "$IMPORT" tdoa "$SRC/tests/data/tdoa/util-style.csv" --out "$WORK/x.lcm"; then
  [ "$(wc -l <"$WORK/err")" -eq 1 ] && grep -q "error: .*util-style.csv: no tag column (columns t,a,b,diff); give --tag T" "$WORK/err" &&
    ok "no tag column: exit 1, one line" || fail "no tag: $(cat "$WORK/err")"
fi
printf 'time,x,y\n1,2,3\n' >"$WORK/nodiff.csv"
if run 1 "$IMPORT" tdoa "$WORK/nodiff.csv" --tag T1 --out "$WORK/x.lcm"; then
  grep -q "error: .*nodiff.csv:" "$WORK/err" && ok "a file of no difference: exit 1" || fail "nodiff: $(cat "$WORK/err")"
fi
head -c 3000 /dev/urandom >"$WORK/garbage.csv"
if run 1 "$IMPORT" tdoa "$WORK/garbage.csv" --tag T1 --out "$WORK/x.lcm"; then
  [ "$(wc -l <"$WORK/err")" -le 2 ] && ok "garbage: exit 1" || fail "garbage: $(head -3 "$WORK/err")"
fi
if run 2 "$IMPORT" tdoa "$WORK/missing.csv" --tag T1 --out "$WORK/x.lcm"; then
  grep -q "no such file" "$WORK/err" && ok "a missing file: exit 2" || fail "missing: $(cat "$WORK/err")"
fi

[ "$failures" -eq 0 ] && echo "all passed" || echo "$failures failed"
exit $((failures > 0))
