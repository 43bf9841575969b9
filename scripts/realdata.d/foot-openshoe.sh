#!/usr/bin/env bash
# foot-openshoe (vdouet/OpenShoe_C, OpenShoe's ISC sources; the folder's LICENSE is CC BY 4.0): a
# foot-mounted IMU, 62.3 s at 820 Hz, rows ax, ay, az (m/s^2), gx, gy, gz (rad/s), no time column.
#   ips-phone-imu --file "OpenShoe C/OpenShoeDataSet.txt" --columns ax,ay,az,gx,gy,gz --rate 820 \
#     --device-id foot1 --out foot.lcm
#   ips-replay foot.lcm --only ins --site site.yaml --out foot-replay.lcm
#   ips-export foot-replay.lcm --channels POSE_INS --format csv --out foot-poses
# site.yaml has no anchors and the tag foot1 starting at the origin, toes along +x, its IMU declared
# on the foot (estimators.ins.foot_imus: no stance phase would be a fault) (ips-ins's
# defaults otherwise). There is no truth: the row gives the number of poses and, in `other`, the
# track's horizontal path length (pose to pose, 10 Hz) and the distance from its end to its start,
# each against the repository's own ZUPT INS, rerun here by openshoe_reference.py (a port of
# OpenShoe_original's GLRT detector and ZUPTaidedINS.m with its settings.m; about 4 s): the walk is
# a figure of eight of about 80 m that ends where it started, and the reference's path and
# end-to-start gap are measured the same way (its positions at 10 Hz). Issue 22's bar: gap at most
# 0.5 m and path within 3 % of the reference's.
# Usage: foot-openshoe.sh <realdata-folder> <work-dir> <bin-dir>
set -euo pipefail
DATA=$1 WORK=$2 BIN=$3
mkdir -p "$WORK"
run() {
  echo "+ $*" >&2
  "$@" >&2 || { echo "foot-openshoe: failed: $(basename "$1") ${2:-} (status $?)" >&2; exit 1; }
}
f="$DATA/OpenShoe C/OpenShoeDataSet.txt"
[ -f "$f" ] || { echo "foot-openshoe: no 'OpenShoe C/OpenShoeDataSet.txt' in $DATA" >&2; exit 1; }
w="$WORK/foot"
printf 'name: foot-openshoe\nanchors: []\ntags:\n  - {id: foot1, start_position: [0, 0, 0], start_heading_deg: 0}\nestimators:\n  ins:\n    foot_imus: [foot1]\n' \
  >"$WORK/site.yaml"
run "$BIN/ips-phone-imu" --file "$f" --columns ax,ay,az,gx,gy,gz --rate 820 --device-id foot1 \
  --out "$w.lcm"
run "$BIN/ips-replay" "$w.lcm" --only ins --site "$WORK/site.yaml" --out "$w-replay.lcm"
run "$BIN/ips-export" "$w-replay.lcm" --channels POSE_INS --format csv --out "$w-poses"
echo "+ openshoe_reference.py (the repository's own ZUPT INS)" >&2
ref=$(python3 "$(dirname "$0")/openshoe_reference.py" "$f") ||
  { echo "foot-openshoe: failed: openshoe_reference.py" >&2; exit 1; }
echo "openshoe reference: $ref" >&2
python3 - "$w-poses/POSE_INS.csv" "$ref" <<'PY'
import csv, math, re, sys
p = [(float(r["position_x_m"]), float(r["position_y_m"])) for r in csv.DictReader(open(sys.argv[1]))]
if not p:
    sys.exit("foot-openshoe: ips-ins gave no pose")
m = re.search(r"path ([0-9.]+) m, end-start ([0-9.]+) m", sys.argv[2])
if not m:
    sys.exit("foot-openshoe: openshoe_reference.py gave no path: " + sys.argv[2])
ref_len, ref_gap = float(m.group(1)), float(m.group(2))
length = sum(math.dist(a, b) for a, b in zip(p, p[1:]))
other = "path %.1fm (%+.1f%% vs OpenShoe's %.1fm), end-start %.2fm (OpenShoe %.2fm)" % (
    length, 100.0 * (length - ref_len) / ref_len, ref_len, math.dist(p[0], p[-1]), ref_gap)
print("\t".join(["foot-openshoe", "OpenShoeDataSet", "ins", str(len(p)), "-", "-", "-", "-",
                 other, "OpenShoe ZUPT INS: path %.1fm, end-start %.2fm" % (ref_len, ref_gap)]))
PY
