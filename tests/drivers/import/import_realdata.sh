#!/usr/bin/env bash
# The real-data path of ips-import on the excerpts kept in tests/data/real (licences allow it):
#   uwb-cucudasluv: 20 s of LOS Trajectory B Case 4, four per-anchor ROS dumps + RTK truth + the
#     authors' LS output, the command lines of scripts/realdata.d/uwb-cucudasluv.sh;
#   uwb-librsf: the whole Indoor_UWB sequence, the command lines of scripts/realdata.d/uwb-librsf.sh.
# Asserts the import counts (rows read, ranges and poses written, SITE first) and accuracy bounds
# honest to what ips-uwb-twr (cucudasluv) and ips-fuse (librsf) achieve today (measured values in the comments; the bounds leave
# about 25 % room), and that the authors' LS output scored here lands near their own figure.
set -uo pipefail
BIN=$(cd "$1" && pwd)
SRC=$(cd "$2" && pwd)
export PYTHONPATH=$SRC/tests/integration  # lcm_log.py
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}
ok() { echo "ok: $*"; }
run() {
  local status=0
  timeout 120 "$@" >"$WORK/out" 2>"$WORK/err" || status=$?
  [ "$status" -eq 0 ] || { fail "$* -> status $status: $(tail -3 "$WORK/err")"; return 1; }
}
# count LOG CHANNEL
count() {
  python3 - "$1" "$2" <<'PY'
import sys, lcm_log
evs, _, _ = lcm_log.events(sys.argv[1])
print(sum(1 for ch, _, _ in evs if ch == sys.argv[2]))
PY
}
# metric JSON CHANNEL TAG FIELD
metric() {
  python3 -c '
import json, sys
rows = [r for r in json.load(open(sys.argv[1]))["rows"] if r["channel"] == sys.argv[2] and r["tag"] == sys.argv[3]]
v = rows[0][sys.argv[4]] if rows else None
print("nan" if v is None else v)' "$@"
}
# below VALUE BOUND
below() { awk -v v="$1" -v b="$2" 'BEGIN { exit !(v == v + 0 && v <= b) }'; }

# --- uwb-cucudasluv ---
D=$SRC/tests/data/real/uwb-cucudasluv
W=$WORK/cucu
if run "$BIN/ips-import" ranges "$D/A3.csv" "$D/A5.csv" "$D/A9.csv" "$D/A12.csv" --tag T1 --with-site \
     --site-name uwb-cucudasluv --out "$W-ranges.lcm"; then
  for a in A3:176 A5:186 A9:191 A12:196; do
    grep -q "${a%%:*}.csv: ${a##*:} rows, ${a##*:} ranges, 0 rejected" "$WORK/err" || fail "cucudasluv ${a%%:*}: $(grep "${a%%:*}.csv" "$WORK/err")"
  done
  n=$(count "$W-ranges.lcm" UWB_RANGE)
  [ "$n" -eq 749 ] && ok "cucudasluv: 749 ranges from 4 files" || fail "cucudasluv ranges: $n"
  first=$(python3 -c 'import sys, lcm_log; print(lcm_log.events(sys.argv[1])[0][0][0])' "$W-ranges.lcm")
  [ "$first" = SITE ] && ok "cucudasluv: SITE first ($(count "$W-ranges.lcm" SITE) SITE)" || fail "first event: $first"
fi
if run "$BIN/ips-import" poses "$D/trajectory.csv" --channel TRUTH --tag T1 --into "$W-ranges.lcm" --out "$W.lcm" &&
   run "$BIN/ips-import" poses "$D/LS.csv" --channel POSE_AUTHORS_LS --tag T1 --into "$W.lcm" &&
   run "$BIN/ips-replay" "$W.lcm" --out "$W-replay.lcm" &&
   run "$BIN/ips-eval" "$W-replay.lcm" --json; then
  cp "$WORK/out" "$W.json"
  [ "$(count "$W.lcm" TRUTH)" -eq 160 ] && ok "cucudasluv: 160 TRUTH" || fail "TRUTH: $(count "$W.lcm" TRUTH)"
  n=$(metric "$W.json" POSE_UWB T1 count) r=$(metric "$W.json" POSE_UWB T1 rmse_h)
  p=$(metric "$W.json" POSE_UWB T1 p95_h)
  # Measured on this 20 s: N 173, 2D RMSE 0.904 m, p95 1.991 m (the whole case: 0.476 / 1.196).
  below "$r" 1.15 && below "$p" 2.5 && [ "$n" -ge 150 ] &&
    ok "cucudasluv uwb_twr: N $n, 2D RMSE $r m, p95 $p m" || fail "cucudasluv uwb_twr: N $n, RMSE $r, p95 $p"
  ls=$(metric "$W.json" POSE_AUTHORS_LS T1 rmse_h)
  # The authors' LS on this 20 s scored here: 1.021 m (whole case: 0.570 here, 0.447 in their
  # RMSD_results.txt); a wrong frame or time base would put it metres off.
  below "$ls" 1.3 && ok "cucudasluv: the authors' LS scored here: 2D RMSE $ls m" || fail "authors' LS: $ls"
fi

# --- uwb-librsf ---
D=$SRC/tests/data/real/uwb-librsf
W=$WORK/librsf
if run "$BIN/ips-import" ranges "$D/Indoor_UWB_Input.txt" --row-tag range2 --columns -,t,range,-,ax,ay,anchor \
     --tag R1 --with-site --site-name uwb-librsf --site-out "$W-site.yaml" --out "$W-ranges.lcm"; then
  grep -q "Indoor_UWB_Input.txt: 233 rows, 233 ranges, 0 rejected" "$WORK/err" && ok "librsf: 233 ranges" ||
    fail "librsf ranges: $(cat "$WORK/err")"
  [ "$(grep -c 'kind: uwb' "$W-site.yaml")" -eq 4 ] && ok "librsf: 4 anchors in the site" || fail "librsf site: $(cat "$W-site.yaml")"
fi
if run "$BIN/ips-import" poses "$D/Indoor_UWB_GT.txt" --row-tag point2 --columns -,t,x,y --tag R1 --channel TRUTH \
     --into "$W-ranges.lcm" --out "$W.lcm" &&
   run "$BIN/ips-replay" "$W.lcm" --out "$W-replay.lcm" &&
   run "$BIN/ips-eval" "$W-replay.lcm" --json; then
  cp "$WORK/out" "$W.json"
  [ "$(count "$W.lcm" TRUTH)" -eq 233 ] && ok "librsf: 233 TRUTH" || fail "librsf TRUTH: $(count "$W.lcm" TRUTH)"
  # ips-uwb-twr never initialises here: the ranges come round-robin 0.128 s apart, so its 0.2 s
  # epoch window (estimators.uwb_twr.epoch_window_s) never holds the 3 it needs; ips-fuse tracks.
  [ "$(metric "$W.json" POSE_UWB R1 count)" = nan ] && ok "librsf: no POSE_UWB (ips-uwb-twr does not initialise)" ||
    ok "librsf: POSE_UWB now has $(metric "$W.json" POSE_UWB R1 count) estimates (update this test's comment)"
  n=$(metric "$W.json" POSE_FUSED R1 count) r=$(metric "$W.json" POSE_FUSED R1 rmse_h)
  p=$(metric "$W.json" POSE_FUSED R1 p95_h)
  # Measured: N 230, 2D RMSE 0.230 m, p95 0.404 m.
  below "$r" 0.30 && below "$p" 0.50 && [ "${n%.*}" -ge 200 ] &&
    ok "librsf fuse: N $n, 2D RMSE $r m, p95 $p m" || fail "librsf fuse: N $n, RMSE $r, p95 $p"
fi

[ "$failures" -eq 0 ] && echo "import_realdata: all passed" || echo "import_realdata: $failures failures"
[ "$failures" -eq 0 ]
