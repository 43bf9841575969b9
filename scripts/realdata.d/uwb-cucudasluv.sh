#!/usr/bin/env bash
# uwb-cucudasluv (cucudasluv/UWB-dataset, Apache-2.0): outdoor DW1000 two-way ranging to 4 anchors,
# RTK-GNSS reference. Each dynamic case (LOS/NLOS x Trajectory A/B x Case 1-4, those present):
#   ips-import ranges A3.csv A5.csv A9.csv A12.csv --tag T1 --with-site --out ranges.lcm
#   ips-import poses trajectory.csv --channel TRUTH --tag T1 --into ranges.lcm --out CASE.lcm
#   ips-import poses LS.csv   --channel POSE_AUTHORS_LS   --tag T1 --into CASE.lcm   (their output,
#   ips-import poses ESKF.csv --channel POSE_AUTHORS_ESKF --tag T1 --into CASE.lcm    scored by us)
#   ips-replay CASE.lcm --out CASE-replay.lcm
#   ips-eval CASE-replay.lcm --json
# The anchors' positions come from the range rows themselves (field.x,y,z, constant per anchor);
# the RTK trajectory is in the same frame (no --offset/--rotate-deg: the ranges' residuals against
# it have a median of a few cm), and so are the authors' LS.csv and ESKF.csv. Scored 2D (the RTK z
# is relative to the start, the tag's height is not given). Rows: uwb_twr (POSE_UWB), fuse
# (POSE_FUSED) when it produced poses, and the authors' own LS and ESKF outputs scored by ips-eval
# as a check of the chain (their RMSD_results.txt figures are the baseline column).
# Usage: uwb-cucudasluv.sh <realdata-folder> <work-dir> <bin-dir>
set -euo pipefail
DATA=$1 WORK=$2 BIN=$3
mkdir -p "$WORK"
say() { echo "uwb-cucudasluv: $*" >&2; }
run() {  # logs the command, runs it, stops the dataset with a one-line reason on failure
  echo "+ $*" >&2
  "$@" >&2 || { echo "uwb-cucudasluv: failed: $(basename "$1") ${2:-} (status $?)" >&2; exit 1; }
}
cases=0
for dir in "$DATA"/Dynamic_measurements/{LOS,NLOS}/Trajectory_{A,B}/Case_*; do
  [ -d "$dir" ] || continue
  env=$(basename "$(dirname "$(dirname "$dir")")")
  traj=$(basename "$(dirname "$dir")"); traj=${traj#Trajectory_}
  num=$(basename "$dir"); num=${num#Case_}
  name="$env $traj$num"
  w="$WORK/${env}_${traj}${num}"
  files=()
  for a in A3 A5 A9 A12; do [ -f "$dir/$a.csv" ] && files+=("$dir/$a.csv"); done
  [ ${#files[@]} -gt 0 ] && [ -f "$dir/trajectory.csv" ] || { say "$name: no range files or trajectory, skipped"; continue; }
  run "$BIN/ips-import" ranges "${files[@]}" --tag T1 --with-site --site-name uwb-cucudasluv \
    --site-out "$w-site.yaml" --out "$w-ranges.lcm"
  run "$BIN/ips-import" poses "$dir/trajectory.csv" --channel TRUTH --tag T1 --into "$w-ranges.lcm" --out "$w.lcm"
  for est in LS ESKF; do
    [ -f "$dir/$est.csv" ] && run "$BIN/ips-import" poses "$dir/$est.csv" --channel "POSE_AUTHORS_$est" --tag T1 --into "$w.lcm"
  done
  run "$BIN/ips-replay" "$w.lcm" --out "$w-replay.lcm"
  run "$BIN/ips-eval" "$w-replay.lcm" --by tag
  "$BIN/ips-eval" "$w-replay.lcm" --json >"$w-eval.json" 2>>"$w-eval.err" ||
    { say "failed: ips-eval --json on $name: $(tail -1 "$w-eval.err")"; exit 1; }
  baseline=-
  if [ -f "$dir/RMSD_results.txt" ]; then
    baseline=$(awk '/LS RMSE_2d/ { ls = $3 } /ESKF RMSE_2d/ { e = $3 }
                    END { if (ls != "") printf "LS %.2f / ESKF %.2f", ls, e; else print "-" }' "$dir/RMSD_results.txt")
  fi
  python3 - "$w-eval.json" "$name" "$baseline" <<'PY'
import json, sys
data = json.load(open(sys.argv[1]))
names = {"POSE_UWB": "uwb_twr", "POSE_FUSED": "fuse",
         "POSE_AUTHORS_LS": "authors' LS (scored here)", "POSE_AUTHORS_ESKF": "authors' ESKF (scored here)"}
def f(v):
    return "-" if v is None else "%.3f" % v
order = ["POSE_UWB", "POSE_FUSED", "POSE_AUTHORS_LS", "POSE_AUTHORS_ESKF"]
rows = {r["channel"]: r for r in data["rows"] if r["tag"] == "T1"}
for ch in order:
    r = rows.get(ch)
    if r is None or r["count"] == 0:
        continue
    print("\t".join(["uwb-cucudasluv", sys.argv[2], names[ch], str(r["count"]), f(r["rmse_h"]),
                     f(r["p95_h"]), f(r["cep50_h"]), f(r["max_h"]), "-", sys.argv[3]]))
PY
  cases=$((cases + 1))
done
[ "$cases" -gt 0 ] || { say "no dynamic case found under $DATA/Dynamic_measurements"; exit 1; }
say "$cases cases"
