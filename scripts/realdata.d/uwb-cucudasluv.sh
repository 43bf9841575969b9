#!/usr/bin/env bash
# uwb-cucudasluv (cucudasluv/UWB-dataset, Apache-2.0): outdoor DW1000 two-way ranging to 4 anchors,
# RTK-GNSS reference. Each dynamic case (LOS/NLOS x Trajectory A/B x Case 1-4, those present):
#   ips-import ranges A3.csv A5.csv A9.csv A12.csv --tag T1 --with-site --out ranges.lcm
#   ips-import poses trajectory.csv --channel TRUTH --tag T1 --into ranges.lcm --out CASE.lcm
#   ips-import poses LS.csv   --channel POSE_AUTHORS_LS   --tag T1 --into CASE.lcm   (their output,
#   ips-import poses ESKF.csv --channel POSE_AUTHORS_ESKF --tag T1 --into CASE.lcm    scored by us)
#   ips-replay CASE.lcm --site SITE+epoch_fixes --out CASE-replay.lcm
#   ips-eval CASE-replay.lcm --json
# The anchors' positions come from the range rows themselves (field.x,y,z, constant per anchor);
# the RTK trajectory is in the same frame (no --offset/--rotate-deg: the ranges' residuals against
# it have a median of a few cm), and so are the authors' LS.csv and ESKF.csv. Scored 2D (the RTK z
# is relative to the start, the tag's height is not given). Rows: uwb_twr (POSE_UWB), fuse
# (POSE_FUSED) when it produced poses, ips-uwb-twr's plain per-epoch least-squares fixes
# (POSE_UWB_EPOCH, the naive solution), and the authors' own LS and ESKF outputs scored by ips-eval
# as a check of the chain (their RMSD_results.txt figures are the baseline column). Then the
# static ranges' error against the known distance, LOS and NLOS (rows "static LOS/NLOS", below),
# and the range our SS-TWR computes from the exchanges' raw DW1000 timestamps (UWB_TWR_RAW) against
# the file's Distance and the known distance (rows "SS-TWR from timestamps").
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
  # The site as imported, plus ips-uwb-twr's plain per-epoch least-squares fixes (POSE_UWB_EPOCH):
  # the naive solution on the same ranges that the tracker and ips-fuse must beat (issue 27).
  printf 'estimators:\n  uwb_twr:\n    epoch_fixes: true\n' >>"$w-site.yaml"
  run "$BIN/ips-replay" "$w.lcm" --site "$w-site.yaml" --out "$w-replay.lcm"
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
names = {"POSE_UWB": "uwb_twr", "POSE_FUSED": "fuse", "POSE_UWB_EPOCH": "per-epoch LS",
         "POSE_AUTHORS_LS": "authors' LS (scored here)", "POSE_AUTHORS_ESKF": "authors' ESKF (scored here)"}
def f(v):
    return "-" if v is None else "%.3f" % v
order = ["POSE_UWB", "POSE_FUSED", "POSE_UWB_EPOCH", "POSE_AUTHORS_LS", "POSE_AUTHORS_ESKF"]
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

# Static ranges (Static_measurements/{LOS,NLOS}/height_H cm/Dm.csv, the file name the true
# distance): each file through the project's own input path,
#   ips-import ranges Dm.csv --tag T1 --out s.lcm; ips-export s.lcm --format csv
# then the range error (range - D) per row: N, RMSE (rmse_h_m column), p95 / median / max of
# |error|, and under "other" the mean error and its std, a least-squares line error = a + b*D,
# and the NLOS indicator's hit rate: the share of ranges with rx - fp power > 10 dB
# (ips-uwb-twr's nlos_power_db, Decawave APS006's "likely NLOS") and > 6 dB ("not clearly LOS"),
# the mean NLOS likelihood the trackers give them (NlosPower: 0 at 6 dB rising to 1 at 10 dB), and
# the mean error of the ranges over 6 dB against the others' (does the indicator pick long ones?).
for env in LOS NLOS; do
  sdir="$DATA/Static_measurements/$env"
  [ -d "$sdir" ] || { say "static $env: no $sdir, skipped"; continue; }
  errs="$WORK/static_${env}_errors.tsv"
  twr="$WORK/static_${env}_twr.tsv" twr_counts="$WORK/static_${env}_twr_counts.tsv"
  : >"$errs"; : >"$twr"; : >"$twr_counts"
  files=0
  for f in "$sdir"/height_*/*m.csv; do
    [ -f "$f" ] || continue
    d=$(basename "$f" .csv); d=${d%m}
    # A few files hold the header only (the recording failed): said, skipped.
    if ! awk -F, 'NR > 1 && NF >= 21 && $1 ~ /^[0-9]/ && $5 ~ /^[0-9]/ { found = 1; exit }
                 END { exit !found }' "$f"; then
      say "static $env: ${f#"$sdir"/}: no data rows, skipped"
      continue
    fi
    s="$WORK/static_${env}.lcm"
    "$BIN/ips-import" ranges "$f" --tag T1 --out "$s" 2>>"$WORK/static_import.err" ||
      { say "static $env: failed: ips-import ranges $f: $(tail -1 "$WORK/static_import.err")"; exit 1; }
    rm -rf "$WORK/static_export"
    "$BIN/ips-export" "$s" --out "$WORK/static_export" --format csv 2>>"$WORK/static_import.err" >&2 ||
      { say "static $env: failed: ips-export $s"; exit 1; }
    # utime_us,source,tag_id,anchor_id,range_m,rx_power_dbm,fp_power_dbm,quality,seq
    awk -F, -v d="$d" 'NR > 1 { print d "\t" ($5 - d) "\t" ($6 - $7) }' \
      "$WORK/static_export/UWB_RANGE.csv" >>"$errs"
    # The exchanges' timestamps (ips-import's UWB_TWR_RAW): utime_us,source,tag_id,anchor_id,seq,
    # tick_s,counter_bits,n_stamps,poll_tx,poll_rx,resp_tx,resp_rx,final_tx,final_rx,
    # clock_offset_ppm,range_m,reported_range_m -> D, file, range_m, Distance, the uncorrected
    # SS-TWR range (Ra - Db)/2 (no clock offset), offset; and the count of ranges for the file.
    n_ranges=$(($(wc -l <"$WORK/static_export/UWB_RANGE.csv") - 1))
    if [ -f "$WORK/static_export/UWB_TWR_RAW.csv" ]; then
      awk -F, -v d="$d" -v f="${f#"$sdir"/}" 'NR > 1 {
          w = 2 ^ $7; ra = ($12 - $9) % w; if (ra < 0) ra += w; db = ($11 - $10) % w; if (db < 0) db += w
          printf "%s\t%s\t%s\t%s\t%.6f\t%s\n", d, f, $16, $17, (ra - db) / 2 * $6 * 299792458.0, $15
        }' "$WORK/static_export/UWB_TWR_RAW.csv" >>"$twr"
    fi
    printf '%s\t%s\n' "${f#"$sdir"/}" "$n_ranges" >>"$twr_counts"
    files=$((files + 1))
  done
  [ "$files" -gt 0 ] || { say "static $env: no Dm.csv files"; continue; }
  python3 - "$errs" "$env" "$files" <<'PY'
import math, sys
d, e, gap = [], [], []
for line in open(sys.argv[1]):
    a, b, c = line.split("\t")
    d.append(float(a)); e.append(float(b))
    c = c.strip().lower()
    gap.append(float(c) if c not in ("nan", "-nan", "") else math.nan)
n = len(e)
if n == 0:
    sys.exit(0)
mean = sum(e) / n
std = math.sqrt(sum((x - mean) ** 2 for x in e) / n)
rmse = math.sqrt(sum(x * x for x in e) / n)
ab = sorted(abs(x) for x in e)
md = sum(d) / n
sxx = sum((x - md) ** 2 for x in d)
b = sum((x - md) * (y - mean) for x, y in zip(d, e)) / sxx if sxx > 0 else 0.0
a = mean - b * md
res = math.sqrt(sum((y - a - b * x) ** 2 for x, y in zip(d, e)) / n)
fin = [g for g in gap if math.isfinite(g)]
share = lambda t: 100.0 * sum(1 for g in fin if g > t) / len(fin) if fin else math.nan
lik = sum(min(1.0, max(0.0, (g - 6.0) / 4.0)) for g in fin) / len(fin) if fin else math.nan
over = [x for x, g in zip(e, gap) if math.isfinite(g) and g > 6]
under = [x for x, g in zip(e, gap) if math.isfinite(g) and g <= 6]
mean_of = lambda v: "%+.3f m" % (sum(v) / len(v)) if v else "-"
other = ("mean error %+.3f m, std %.3f m; fit %+.3f %+.4f*D m (residual std %.3f m), D %g-%g m, %s files; "
         "rx-fp > 10 dB %.2f %%, > 6 dB %.2f %% of %d with powers, mean NLOS likelihood %.4f; "
         "mean error over 6 dB %s (%d), under %s") % (
    mean, std, a, b, res, min(d), max(d), sys.argv[3], share(10), share(6), len(fin), lik,
    mean_of(over), len(over), mean_of(under))
print("\t".join(["uwb-cucudasluv", "static " + sys.argv[2], "ranges (range - D)", str(n), "%.3f" % rmse,
                 "%.3f" % ab[min(n - 1, int(0.95 * n))], "%.3f" % ab[n // 2], "%.3f" % ab[-1], other, "-"]))
PY
  # SS-TWR from the timestamps: error against the known distance D (N, RMSE, p95 / median / max of
  # |error|), under "other" the residual against the file's Distance (mean, std, max |.|) with the
  # clock offset measured across exchanges and without any, the same against D, the offsets seen,
  # the exchanges without an offset yet (each file's first) and the rows whose stamps ips-import
  # refused (not consistent with rtd_init/rtd_resp); the file with the largest mean residual
  # against Distance. Per file: $WORK/static_<env>_twr_per_file.tsv.
  python3 - "$twr" "$twr_counts" "$env" "$WORK/static_${env}_twr_per_file.tsv" <<'PY'
import math, sys
rows = []
for line in open(sys.argv[1]):
    d, f, r, rep, unc, off = line.rstrip("\n").split("\t")
    fl = lambda v: float(v) if v.lower() not in ("nan", "-nan", "") else math.nan
    rows.append((float(d), f, fl(r), fl(rep), float(unc), fl(off)))
ranges = sum(int(l.split("\t")[1]) for l in open(sys.argv[2]))
if not rows:
    sys.exit(0)
def stats(v):
    n = len(v)
    if n == 0:
        return (0, math.nan, math.nan, math.nan)
    m = sum(v) / n
    return (n, m, math.sqrt(sum((x - m) ** 2 for x in v) / n), max(abs(x) for x in v))
corr = [r for r in rows if math.isfinite(r[5]) and math.isfinite(r[2])]
vs_dist = [r[2] - r[3] for r in corr if math.isfinite(r[3])]
vs_dist_unc = [r[4] - r[3] for r in rows if math.isfinite(r[3])]
vs_true = [r[2] - r[0] for r in corr]
vs_true_unc = [r[4] - r[0] for r in rows]
offs = sorted(r[5] for r in corr)
per_file = {}
for r in corr:
    per_file.setdefault(r[1], []).append(r)
with open(sys.argv[4], "w") as out:
    out.write("file\tD_m\tN\tvs_distance_mean_m\tvs_distance_std_m\tvs_distance_max_m\tvs_D_mean_m\tvs_D_std_m\toffset_median_ppm\n")
    worst = None
    for f in sorted(per_file):
        v = per_file[f]
        a = stats([r[2] - r[3] for r in v if math.isfinite(r[3])])
        b = stats([r[2] - r[0] for r in v])
        o = sorted(r[5] for r in v)[len(v) // 2]
        out.write("%s\t%g\t%d\t%+.4f\t%.4f\t%.4f\t%+.4f\t%.4f\t%+.3f\n" % (f, v[0][0], a[0], a[1], a[2], a[3], b[1], b[2], o))
        if a[0] and (worst is None or abs(a[1]) > abs(worst[1])):
            worst = (f, a[1])
n = len(vs_true)
ab = sorted(abs(x) for x in vs_true)
rmse = math.sqrt(sum(x * x for x in vs_true) / n) if n else math.nan
sd, sdu, st, stu = stats(vs_dist), stats(vs_dist_unc), stats(vs_true), stats(vs_true_unc)
q = lambda p: offs[min(len(offs) - 1, int(p * len(offs)))] if offs else math.nan
other = ("vs Distance: mean %+.3f, std %.3f, max %.3f m (uncorrected %+.3f, %.3f, %.3f); "
         "vs D: mean %+.3f, std %.3f m (uncorrected %+.3f, %.3f); offset median %+.2f ppm (5-95 %% %+.2f..%+.2f); "
         "%d files, %d exchanges, %d without an offset yet, %d rows' stamps refused; worst file %s (%+.3f m)") % (
    sd[1], sd[2], sd[3], sdu[1], sdu[2], sdu[3], st[1], st[2], stu[1], stu[2], q(0.5), q(0.05), q(0.95),
    len(per_file), len(rows), len(rows) - len(corr), ranges - len(rows),
    worst[0] if worst else "-", worst[1] if worst else math.nan)
print("\t".join(["uwb-cucudasluv", "static " + sys.argv[3], "SS-TWR from timestamps (range - D)", str(n),
                 "%.3f" % rmse, "%.3f" % ab[min(n - 1, int(0.95 * n))], "%.3f" % ab[n // 2], "%.3f" % ab[-1],
                 other, "-"]))
PY
done
