#!/usr/bin/env bash
# uwb-librsf (TUC-ProAut/libRSF datasets/Indoor_UWB, CC BY-SA 4.0): 233 indoor ranges over 30 s
# to 4 anchors on a 2.4 m square, 2D ground truth. Tagged lines (readme.txt of the folder):
#   ips-import ranges Indoor_UWB_Input.txt --row-tag range2 --columns -,t,range,-,ax,ay,anchor \
#     --tag R1 --with-site --out ranges.lcm
#   ips-import poses Indoor_UWB_GT.txt --row-tag point2 --columns -,t,x,y --tag R1 \
#     --channel TRUTH --into ranges.lcm --out librsf.lcm
#   ips-replay librsf.lcm --site SITE+epoch_fixes --out librsf-replay.lcm (plain per-epoch
#     least-squares fixes on POSE_UWB_EPOCH beside the tracker's)
#   ips-eval librsf-replay.lcm --json
# The anchors' positions come from the range rows (anchorX, anchorY; no z: a planar site, the tag
# at height 0, so the trackers solve in 2D). The times are seconds from the recording's start and
# are kept as they are (both files share that clock). No published figure to compare with.
# Usage: uwb-librsf.sh <realdata-folder> <work-dir> <bin-dir>
set -euo pipefail
DATA=$1 WORK=$2 BIN=$3
mkdir -p "$WORK"
run() {
  echo "+ $*" >&2
  "$@" >&2 || { echo "uwb-librsf: failed: $(basename "$1") ${2:-} (status $?)" >&2; exit 1; }
}
for f in Indoor_UWB_Input.txt Indoor_UWB_GT.txt; do
  [ -f "$DATA/$f" ] || { echo "uwb-librsf: no $f in $DATA" >&2; exit 1; }
done
w="$WORK/librsf"
run "$BIN/ips-import" ranges "$DATA/Indoor_UWB_Input.txt" --row-tag range2 \
  --columns -,t,range,-,ax,ay,anchor --tag R1 --with-site --site-name uwb-librsf \
  --site-out "$w-site.yaml" --out "$w-ranges.lcm"
run "$BIN/ips-import" poses "$DATA/Indoor_UWB_GT.txt" --row-tag point2 --columns -,t,x,y --tag R1 \
  --channel TRUTH --into "$w-ranges.lcm" --out "$w.lcm"
# The site as imported, plus ips-uwb-twr's plain per-epoch least-squares fixes (POSE_UWB_EPOCH):
# the naive solution on the same ranges that the tracker and ips-fuse must beat (issue 27).
printf 'estimators:\n  uwb_twr:\n    epoch_fixes: true\n' >>"$w-site.yaml"
run "$BIN/ips-replay" "$w.lcm" --site "$w-site.yaml" --out "$w-replay.lcm"
run "$BIN/ips-eval" "$w-replay.lcm" --by tag
"$BIN/ips-eval" "$w-replay.lcm" --json >"$w-eval.json" 2>"$w-eval.err" ||
  { echo "uwb-librsf: failed: ips-eval --json: $(tail -1 "$w-eval.err")" >&2; exit 1; }
python3 - "$w-eval.json" <<'PY'
import json, sys
data = json.load(open(sys.argv[1]))
names = {"POSE_UWB": "uwb_twr", "POSE_FUSED": "fuse", "POSE_UWB_EPOCH": "per-epoch LS"}
def f(v):
    return "-" if v is None else "%.3f" % v
rows = {r["channel"]: r for r in data["rows"] if r["tag"] == "R1"}
n = 0
for ch in ["POSE_UWB", "POSE_FUSED", "POSE_UWB_EPOCH"]:
    r = rows.get(ch)
    if (r is None or r["count"] == 0) and ch == "POSE_UWB_EPOCH":
        print("\t".join(["uwb-librsf", "Indoor_UWB", names[ch], "0", "-", "-", "-", "-", "-", "-"]))
        continue
    if r is None or r["count"] == 0:
        # Said, not hidden: a tracker that made no estimate gets a row with N 0.
        print("\t".join(["uwb-librsf", "Indoor_UWB", names[ch], "0", "-", "-", "-", "-", "-", "-"]))
        print("uwb-librsf: %s made no estimate (see ips-replay's line above)" % names[ch], file=sys.stderr)
        continue
    n += 1
    print("\t".join(["uwb-librsf", "Indoor_UWB", names[ch], str(r["count"]), f(r["rmse_h"]),
                     f(r["p95_h"]), f(r["cep50_h"]), f(r["max_h"]), "-", "-"]))
if n == 0:
    sys.exit("uwb-librsf: no estimate was scored (POSE_UWB and POSE_FUSED empty)")
PY
