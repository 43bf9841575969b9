#!/usr/bin/env bash
# ble-byongho96 (Byongho96/ble-localization; no licence stated: read in place, never copied): four
# u-blox XPLR-AOA anchors, one tag (6C1DEBA3FFAC), one file of decoded +UUDF fields per anchor
# (epoch ms). Each recording whose anchor layout the dataset gives (collected-config.yml):
#   ips-ble-aoa --capture anchor1/F anchor2/F anchor3/F anchor4/F \
#     --anchor-name 6C1DEBA09949=A1 --anchor-name CCF9579B236F=A2 \
#     --anchor-name 6C1DEBA09A56=A3 --anchor-name 6C1DEBA09A70=A4 \
#     --tag-name 6C1DEBA3FFAC=T1 --out CASE.lcm
# then per solver mode (the site's estimators.aoa.method: ekf, per_epoch with the LM solver):
#   ips-replay CASE.lcm --site SITE-with-mode.yaml --only aoa --out CASE-MODE.lcm
#   ips-export CASE-MODE.lcm --channels POSE_AOA --format csv --out CASE-MODE/
# Static grids (truth: dwell intervals, cm) are also scored by
#   ips-eval CASE-MODE.lcm --dwell GT.csv --dwell-columns -,start,-,end,x,y,z --dwell-unit cm
# (--dwell-columns by position: 0317's header swaps two names); the figures of the row are the
# same dwell rule computed here from the exported poses (checked equal to ips-eval's N and RMSE:
# the script stops when they differ). Walks (0416 rectangular-*, 0421 diagonal-N, set-N,
# set-stop-N, low-1, set-low-N): the truth is way points with the time the walker was at each; a
# pose between the times of points i and i+1 is scored by its horizontal distance to that leg
# (cross-track plus any along-track overshoot beyond the leg's ends; not the distance along it,
# which the way-point times are too coarse for). Rows: estimator aoa-ekf / aoa-lm, per case and
# pooled (static, walks: RMSE over every scored pose of the group); `other`: the share of ALL
# poses (scored or not) within 5 cm of an anchor horizontally, and the worst horizontal distance
# outside the anchors' bounding box. Not run: mobility (2022, numeric ids, a layout of config.yml
# whose mounting heights are not given), 0409/0414 (one anchor), 0317 floor/obstacle (no layout).
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
MODES="ekf lm"
site_for() {  # layout mode -> a site file with that solver mode
  local out="$WORK/site-$1-$2.yaml"
  cp "$SITES/ble-byongho96-$1.yaml" "$out"
  if ! grep -q '^estimators:' "$out"; then
    case $2 in
      ekf) printf 'estimators:\n  aoa:\n    method: ekf\n' >> "$out" ;;
      lm) printf 'estimators:\n  aoa:\n    method: per_epoch\n    solver: lm\n' >> "$out" ;;
    esac
  else
    say "the site $1 has its own estimators section: mode $2 cannot be set"; exit 1
  fi
  echo "$out"
}
list=$WORK/scored.tsv  # kind case mode export-csv truth site
: > "$list"
cases=0
# kind case anchor-files(%a: anchor number) layout truth...
while read -r kind name files layout gts; do
  [ -n "$kind" ] || continue
  w="$WORK/$name"
  args=()
  for a in 1 2 3 4; do
    f="$DATA/dataset/${files//%a/$a}"
    [ -f "$f" ] && args+=("$f")
  done
  [ ${#args[@]} -eq 4 ] || { say "$name: anchor files missing, skipped"; continue; }
  truth=()
  for g in $gts; do [ -f "$DATA/dataset/$g" ] && truth+=("$DATA/dataset/$g"); done
  [ ${#truth[@]} -gt 0 ] || { say "$name: truth missing, skipped"; continue; }
  run "$BIN/ips-ble-aoa" --capture "${args[@]}" "${NAMES[@]}" --out "$w.lcm"
  for mode in $MODES; do
    site=$(site_for "$layout" "$mode")
    run "$BIN/ips-replay" "$w.lcm" --site "$site" --only aoa --out "$w-$mode.lcm"
    run "$BIN/ips-export" "$w-$mode.lcm" --channels POSE_AOA --format csv --out "$w-$mode"
    if [ "$kind" = static ]; then
      "$BIN/ips-eval" "$w-$mode.lcm" --dwell "${truth[0]}" --dwell-columns -,start,-,end,x,y,z \
        --dwell-unit cm --json >"$w-$mode-eval.json" 2>"$w-$mode-eval.err" ||
        { say "failed: ips-eval --json on $name: $(tail -1 "$w-$mode-eval.err")"; exit 1; }
    fi
    printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$kind" "$name" "$mode" "$w-$mode/POSE_AOA.csv" \
      "${truth[*]}" "$site" >> "$list"
  done
  cases=$((cases + 1))
done <<'CASES'
static 0317-rectangular 0317/anchor%a/rectangular.csv rectangular 0317/gt/rectangular.csv
static 0317-diagonal 0317/anchor%a/diagonal.csv diagonal 0317/gt/diagonal.csv
static 0421-grid 0421/beacons/anchor%a/diagonal-grid.csv 0421 0421/gt/grid.csv
walk 0416-edge 0416/beacons/rectangular-edge/anchor%a.csv 0416 0416/gt/rectangular-edge.csv 0416/gt/rectangular-edge-low.csv
walk 0416-mid 0416/beacons/rectangular-mid/anchor%a.csv 0416 0416/gt/rectangular-mid.csv 0416/gt/rectangular-mid-2.csv 0416/gt/rectangular-mid-low.csv 0416/gt/rectangular-mid-reverse.csv
walk 0421-diagonal 0421/beacons/anchor%a/diagonal.csv 0421 0421/gt/diagonal-1.csv 0421/gt/diagonal-2.csv 0421/gt/diagonal-3.csv 0421/gt/diagonal-4.csv
walk 0421-set 0421/beacons/anchor%a/diagonal-set.csv 0421 0421/gt/set-1.csv 0421/gt/set-2.csv 0421/gt/set-3.csv 0421/gt/set-4.csv 0421/gt/set-stop-1.csv 0421/gt/set-stop-2.csv 0421/gt/set-stop-3.csv 0421/gt/set-low-1.csv 0421/gt/set-low-2.csv 0421/gt/set-low-3.csv
walk 0421-low 0421/beacons/anchor%a/diagonal-low.csv 0421 0421/gt/low-1.csv
CASES
[ "$cases" -gt 0 ] || { say "no recording found under $DATA/dataset"; exit 1; }
python3 - "$list" "$WORK" <<'PY'
import csv, json, math, os, re, sys
listing, work = sys.argv[1], sys.argv[2]
def f(v):
    return "-" if v is None else "%.3f" % v
def stats(err):
    if not err:
        return None
    e = sorted(err)
    n = len(e)
    def q(p):  # nearest rank, as ips-eval
        return e[min(n - 1, max(0, math.ceil(p * n) - 1))]
    return n, math.sqrt(sum(x * x for x in e) / n), q(0.95), q(0.5), e[-1]
def anchors(site):
    out = []
    for line in open(site):
        m = re.search(r"position:\s*\[([-0-9.]+),\s*([-0-9.]+)", line)
        if m and "kind: ble_aoa" in line:
            out.append((float(m.group(1)), float(m.group(2))))
    return out
def poses(path):
    rows = []
    with open(path) as fh:
        for r in csv.DictReader(fh):
            if r["tag_id"] != "T1":
                continue
            x, y = float(r["position_x_m"]), float(r["position_y_m"])
            if math.isfinite(x) and math.isfinite(y):
                rows.append((int(r["utime_us"]) / 1e6, x, y))
    return rows
def truth_rows(path):
    out = []
    with open(path) as fh:
        rd = csv.reader(fh)
        next(rd)
        for r in rd:
            out.append(r)
    return out
def dwell_errors(p, gt):  # columns by position: -,start,-,end,x,y,z in cm, epoch ms
    iv = []
    for r in truth_rows(gt):
        try:
            iv.append((float(r[1]) / 1e3, float(r[3]) / 1e3, float(r[4]) / 100, float(r[5]) / 100))
        except (ValueError, IndexError):
            pass
    err = []
    for t, x, y in p:
        for a, b, tx, ty in iv:
            if a <= t <= b:
                err.append(math.hypot(x - tx, y - ty))
                break
    return err
def seg_dist(x, y, a, b):
    ax, ay = a; bx, by = b
    dx, dy = bx - ax, by - ay
    L2 = dx * dx + dy * dy
    s = 0.0 if L2 == 0 else max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / L2))
    return math.hypot(x - ax - s * dx, y - ay - s * dy)
def walk_errors(p, gt):  # StartTimestamp (ms) is column 1 (2025 files), X, Y in cm
    pts = []
    for r in truth_rows(gt):
        try:
            pts.append((float(r[1]) / 1e3, float(r[4]) / 100, float(r[5]) / 100))
        except (ValueError, IndexError):
            pass
    err = []
    for t, x, y in p:
        for i in range(len(pts) - 1):
            if pts[i][0] <= t < pts[i + 1][0]:
                err.append(seg_dist(x, y, pts[i][1:], pts[i + 1][1:]))
                break
    return err
def other(p, anc):
    near = sum(1 for _, x, y in p if min(math.hypot(x - ax, y - ay) for ax, ay in anc) < 0.05)
    x0, x1 = min(a[0] for a in anc), max(a[0] for a in anc)
    y0, y1 = min(a[1] for a in anc), max(a[1] for a in anc)
    out = max([math.hypot(max(x0 - x, 0, x - x1), max(y0 - y, 0, y - y1)) for _, x, y in p] or [0])
    return near, len(p), out
pooled = {}
order = []
for line in open(listing):
    kind, name, mode, exported, truth, site = line.rstrip("\n").split("\t")
    p = poses(exported)
    err = []
    for gt in truth.split(" "):
        err += dwell_errors(p, gt) if kind == "static" else walk_errors(p, gt)
    if kind == "static":
        ev = json.load(open(os.path.join(work, name + "-" + mode + "-eval.json")))
        rows = [r for r in ev["rows"] if r["channel"] == "POSE_AOA" and r["tag"] == "T1"]
        n_eval = rows[0]["count"] if rows else 0
        if n_eval != len(err) or (err and abs(rows[0]["rmse_h"] - stats(err)[1]) > 1e-3):
            sys.exit("ble-byongho96: %s %s: dwell scoring here (%d) differs from ips-eval (%d)"
                     % (name, mode, len(err), n_eval))
    near, total, out = other(p, anchors(site))
    key = (kind, mode)
    if key not in pooled:
        pooled[key] = [[], 0, 0, 0.0]
        order.append(key)
    pooled[key][0] += err
    pooled[key][1] += near
    pooled[key][2] += total
    pooled[key][3] = max(pooled[key][3], out)
    s = stats(err)
    if s is None:
        continue
    oth = "near-anchor %.2f%% of %d; outside %.2f m" % (100.0 * near / max(total, 1), total, out)
    print("\t".join(["ble-byongho96", name, "aoa-" + mode, str(s[0]), f(s[1]), f(s[2]), f(s[3]),
                     f(s[4]), oth, "-"]))
for kind, mode in order:
    err, near, total, out = pooled[(kind, mode)]
    s = stats(err)
    if s is None:
        continue
    oth = "near-anchor %.2f%% of %d; outside %.2f m" % (100.0 * near / max(total, 1), total, out)
    print("\t".join(["ble-byongho96", "pooled-" + ("static" if kind == "static" else "walks"),
                     "aoa-" + mode, str(s[0]), f(s[1]), f(s[2]), f(s[3]), f(s[4]), oth, "-"]))
PY
say "$cases recordings"
