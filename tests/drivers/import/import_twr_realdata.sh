#!/usr/bin/env bash
# ips-import ranges on the committed excerpt of uwb-cucudasluv's static rows
# (tests/data/real/uwb-cucudasluv/static_LOS_h100_30m.csv: 20 DW1000 SS-TWR exchanges with their
# raw timestamps, true distance 30 m; Apache-2.0, SOURCE.md there), through the programs:
# UWB_TWR_RAW beside UWB_RANGE, read back with ips-export; the range our SS-TWR computes from the
# stamps against the file's Distance (measured: mean +0.009 m, max 0.027 m over the 19 exchanges
# with a clock offset; uncorrected the first is +0.20 m); --range-from timestamps puts those
# ranges into UWB_RANGE.
# Usage: import_twr_realdata.sh <bin-dir> <source-dir>
set -uo pipefail
BIN=$(cd "$1" && pwd)
SRC=$(cd "$2" && pwd)
F=$SRC/tests/data/real/uwb-cucudasluv/static_LOS_h100_30m.csv
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
ok() { echo "ok: $*"; }

if timeout 60 "$BIN/ips-import" ranges "$F" --tag T1 --out "$WORK/s.lcm" 2>"$WORK/err"; then
  grep -q "static_LOS_h100_30m.csv: 20 rows, 20 ranges, 0 rejected" "$WORK/err" &&
    grep -q "static_LOS_h100_30m.csv: 20 exchanges with timestamps (20 SS-TWR, 0 DS-TWR); clock offset from 19 intervals" "$WORK/err" &&
    ok "import: 20 ranges, 20 exchanges, 19 clock offsets" || fail "import summary: $(cat "$WORK/err")"
  if timeout 60 "$BIN/ips-export" "$WORK/s.lcm" --out "$WORK/x" --format csv 2>>"$WORK/err" >/dev/null; then
    python3 - "$WORK/x" <<'PY' && ok "$(cat "$WORK/x/verdict")" || fail "$(cat "$WORK/x/verdict" 2>/dev/null)"
import csv, math, sys
d = sys.argv[1]
ranges = list(csv.DictReader(open(d + "/UWB_RANGE.csv")))
twr = list(csv.DictReader(open(d + "/UWB_TWR_RAW.csv")))
ok = len(ranges) == 20 and len(twr) == 20
res = []
for r, x in zip(ranges, twr):
    ok = ok and r["utime_us"] == x["utime_us"] and r["seq"] == x["seq"] and x["n_stamps"] == "4"
    ok = ok and x["counter_bits"] == "32" and float(x["reported_range_m"]) == float(r["range_m"])
    if x["clock_offset_ppm"] != "NaN":
        res.append(float(x["range_m"]) - float(x["reported_range_m"]))
mean = sum(res) / len(res) if res else math.nan
worst = max(abs(e) for e in res) if res else math.nan
first = float(twr[0]["range_m"]) - float(twr[0]["reported_range_m"]) if twr else math.nan
ok = ok and len(res) == 19 and abs(mean) < 0.02 and worst < 0.04 and 0.15 < first < 0.25
open(d + "/verdict", "w").write("SS-TWR from the stamps against Distance: %d exchanges, mean %+.4f m, "
                               "max %.4f m; the first, uncorrected: %+.3f m" % (len(res), mean, worst, first))
sys.exit(0 if ok else 1)
PY
  else
    fail "ips-export: $(tail -2 "$WORK/err")"
  fi
else
  fail "ips-import: $(tail -3 "$WORK/err")"
fi

# --range-from timestamps: 19 ranges (the first has no clock offset yet: rejected, counted).
if timeout 60 "$BIN/ips-import" ranges "$F" --tag T1 --range-from timestamps --out "$WORK/t.lcm" 2>"$WORK/err2" &&
   timeout 60 "$BIN/ips-export" "$WORK/t.lcm" --out "$WORK/y" --format csv >/dev/null 2>>"$WORK/err2"; then
  grep -q "19 rows, 19 ranges, 1 rejected (first: line 2: no clock offset yet" "$WORK/err2" || fail "range-from summary: $(head -1 "$WORK/err2")"
  python3 - "$WORK/x/UWB_TWR_RAW.csv" "$WORK/y/UWB_RANGE.csv" <<'PY' && ok "--range-from timestamps: 19 ranges, those of UWB_TWR_RAW" || fail "--range-from timestamps ranges differ"
import csv, sys
twr = list(csv.DictReader(open(sys.argv[1])))[1:]
rng = list(csv.DictReader(open(sys.argv[2])))
sys.exit(0 if len(rng) == 19 and all(float(a["range_m"]) == float(b["range_m"]) for a, b in zip(twr, rng)) else 1)
PY
else
  fail "--range-from timestamps: $(tail -3 "$WORK/err2")"
fi

# Bad flags are a usage error.
timeout 10 "$BIN/ips-import" ranges "$F" --tag T1 --range-from bogus --out "$WORK/z.lcm" 2>/dev/null
[ $? -eq 2 ] && ok "--range-from bogus: status 2" || fail "--range-from bogus not refused"

[ "$failures" -eq 0 ] && echo "import_twr_realdata: all passed" || { echo "import_twr_realdata: $failures failed"; exit 1; }
