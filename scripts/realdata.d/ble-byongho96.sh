#!/usr/bin/env bash
# ble-byongho96 (Byongho96/ble-localization; no licence stated: read in place, never copied): four
# u-blox XPLR-AOA anchors, one tag (6C1DEBA3FFAC), one file of decoded +UUDF fields per anchor
# (epoch ms), truth as static dwell intervals (cm). Each static recording whose anchor layout the
# dataset gives (collected-config.yml) and whose truth has dwell intervals:
#   ips-ble-aoa --capture anchor1/F anchor2/F anchor3/F anchor4/F \
#     --anchor-name 6C1DEBA09949=A1 --anchor-name CCF9579B236F=A2 \
#     --anchor-name 6C1DEBA09A56=A3 --anchor-name 6C1DEBA09A70=A4 \
#     --tag-name 6C1DEBA3FFAC=T1 --out CASE.lcm
#   ips-replay CASE.lcm --site config/sites/realdata/ble-byongho96-LAYOUT.yaml --only aoa \
#     --out CASE-replay.lcm
#   ips-eval CASE-replay.lcm --dwell GT.csv --dwell-columns -,start,-,end,x,y,z --dwell-unit cm --json
# --dwell-columns by position: the truth files' rows are StartTimeISO,StartTimestamp,EndTimeISO,
# EndTimestamp,X,Y,Z whatever their header says (0317's header swaps two names). Rows: aoa
# (POSE_AOA), 2D (the site gives the tag's height, the truth's Z). The walks (0416, 0421
# diagonal-N, mobility) have way points without times at the points, and 0317's floor,
# floor-horizontal and obstacle recordings have no layout in the config files: not scored.
# Usage: ble-byongho96.sh <realdata-folder> <work-dir> <bin-dir>
set -euo pipefail
DATA=$1 WORK=$2 BIN=$3
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SITES=$ROOT/config/sites/realdata
mkdir -p "$WORK"
say() { echo "ble-byongho96: $*" >&2; }
run() {  # logs the command, runs it, stops the dataset with a one-line reason on failure
  echo "+ $*" >&2
  "$@" >&2 || { echo "ble-byongho96: failed: $(basename "$1") ${2:-} (status $?)" >&2; exit 1; }
}
NAMES=(--anchor-name 6C1DEBA09949=A1 --anchor-name CCF9579B236F=A2 --anchor-name 6C1DEBA09A56=A3
       --anchor-name 6C1DEBA09A70=A4 --tag-name 6C1DEBA3FFAC=T1)
cases=0
# case  anchor files (relative, with %a for the anchor number)  truth  layout
while read -r name files gt layout; do
  w="$WORK/${name//[ \/]/_}"
  args=()
  for a in 1 2 3 4; do
    f="$DATA/dataset/${files//%a/$a}"
    [ -f "$f" ] && args+=("$f")
  done
  [ ${#args[@]} -eq 4 ] && [ -f "$DATA/dataset/$gt" ] || { say "$name: files missing, skipped"; continue; }
  run "$BIN/ips-ble-aoa" --capture "${args[@]}" "${NAMES[@]}" --out "$w.lcm"
  run "$BIN/ips-replay" "$w.lcm" --site "$SITES/ble-byongho96-$layout.yaml" --only aoa --out "$w-replay.lcm"
  ev=("$BIN/ips-eval" "$w-replay.lcm" --dwell "$DATA/dataset/$gt" --dwell-columns -,start,-,end,x,y,z
      --dwell-unit cm)
  run "${ev[@]}"
  "${ev[@]}" --json >"$w-eval.json" 2>"$w-eval.err" ||
    { say "failed: ips-eval --json on $name: $(tail -1 "$w-eval.err")"; exit 1; }
  python3 - "$w-eval.json" "$name" <<'PY'
import json, sys
data = json.load(open(sys.argv[1]))
def f(v):
    return "-" if v is None else "%.3f" % v
for r in data["rows"]:
    if r["channel"] != "POSE_AOA" or r["tag"] != "T1" or r["count"] == 0:
        continue
    print("\t".join(["ble-byongho96", sys.argv[2], "aoa", str(r["count"]), f(r["rmse_h"]),
                     f(r["p95_h"]), f(r["cep50_h"]), f(r["max_h"]), "-", "-"]))
PY
  cases=$((cases + 1))
done <<'CASES'
0317-rectangular 0317/anchor%a/rectangular.csv 0317/gt/rectangular.csv rectangular
0317-diagonal 0317/anchor%a/diagonal.csv 0317/gt/diagonal.csv diagonal
0421-grid 0421/beacons/anchor%a/diagonal-grid.csv 0421/gt/grid.csv 0421
CASES
[ "$cases" -gt 0 ] || { say "no recording found under $DATA/dataset"; exit 1; }
say "$cases cases"
