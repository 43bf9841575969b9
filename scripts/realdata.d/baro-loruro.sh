#!/usr/bin/env bash
# baro-loruro (github.com/loruro/Barometer_STM32, GPL-3.0: read in place, never copied): a BMP180
# (and an MPL115A1) at rest at each oversampling setting (in_place/oss_0..3.log) and carried up
# and down the stairs of two buildings (changing_altitude/{up,down}_{b5,kapitol}.log).
#   scripts/realdata.d/baro-loruro.sh <realdata-folder-path> <work-dir> <bin-dir>
# Each file: ips-baro --file (times: the rows spread evenly between the banner's start and end
# dates, the derived rate printed) -> ips-replay hosting ips-altitude with
# config/sites/realdata/baro-loruro.yaml. The recordings have no reference station: ips-baro's
# --start-reference T1 publishes T1.start at 0 m holding the BMP180's mean of the file's first
# second, so heights are changes since the start. Figures, for the BMP180 (tag T1):
#   at rest: ips-eval --static-point 0,0,0 (truth: no change): N, RMSE, p95, max of the filtered
#            height; other = its standard deviation, and the raw per-sample height noise (the
#            BMP180 pressures' standard deviation in m, from ips-baro's summary);
#   stairs:  the filtered height's last value minus its first (ips-export of ALTITUDE) against the
#            author's assumed totals, +-45 m (Kapitol) and +-33 m (B5), rough.
# TAB-separated rows on stdout (scripts/realdata's contract); progress on stderr.
set -euo pipefail
src=$1 work=$2 bin=$3
repo=$(cd "$(dirname "$0")/../.." && pwd)
site=$repo/config/sites/realdata/baro-loruro.yaml
m=$src/measurements
mkdir -p "$work"
die() { echo "baro-loruro: $*" >&2; exit 1; }
[ -d "$m/in_place" ] && [ -d "$m/changing_altitude" ] || die "no $m/in_place or changing_altitude"

# ips-baro --file -> ips-replay (altitude); prints ips-baro's T1 summary line on stderr.
chain() {
  local case=$1 file=$2
  echo "+ ips-baro --file $file --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC --start-reference T1 --out $work/$case.baro.lcm" >&2
  "$bin/ips-baro" --file "$file" --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC \
    --start-reference T1 --out "$work/$case.baro.lcm" 2>"$work/$case.baro.txt" ||
    die "$case: ips-baro failed: $(tail -1 "$work/$case.baro.txt")"
  sed 's/^/  /' "$work/$case.baro.txt" >&2
  echo "+ ips-replay $work/$case.baro.lcm --only altitude --site $site --out $work/$case.lcm" >&2
  "$bin/ips-replay" "$work/$case.baro.lcm" --only altitude --site "$site" \
    --out "$work/$case.lcm" >"$work/$case.replay.txt" 2>&1 ||
    die "$case: ips-replay failed: $(tail -1 "$work/$case.replay.txt")"
}

json() {  # json FILE EXPR: a field of ips-eval --json's T1 altitude row, 3 decimals
  python3 -c '
import json, math, sys
d = json.load(open(sys.argv[1]))
rows = [r for r in d.get("altitude", []) if r.get("tag") == "T1"]
if not rows: sys.exit("no ALTITUDE row for T1")
r = rows[0]
v = eval(sys.argv[2], {"math": math}, {"r": r})
print(v if isinstance(v, int) else "%.3f" % v)' "$1" "$2"
}

for k in 0 1 2 3; do
  case=in_place/oss_$k
  chain "oss_$k" "$m/$case.log"
  "$bin/ips-eval" --json --static-point 0,0,0 "$work/oss_$k.lcm" >"$work/oss_$k.eval.json" \
    2>"$work/oss_$k.eval.txt" || die "$case: ips-eval failed: $(tail -1 "$work/oss_$k.eval.txt")"
  n=$(json "$work/oss_$k.eval.json" 'r["count"]')
  rmse=$(json "$work/oss_$k.eval.json" 'r["rmse_v"]')
  p95=$(json "$work/oss_$k.eval.json" 'r["p95_v"]')
  max=$(json "$work/oss_$k.eval.json" 'r["max_v"]')
  std=$(json "$work/oss_$k.eval.json" 'math.sqrt(max(0.0, r["rmse_v"]**2 - r["bias_v"]**2))')
  raw=$(sed -n 's/.*sensor T1: .* (\([0-9.]*\) m of height per sample).*/\1/p' "$work/oss_$k.baro.txt")
  [ -n "$raw" ] || die "$case: no T1 noise in ips-baro's summary"
  printf 'baro-loruro\t%s\taltitude\t%s\t%s\t%s\t-\t%s\tstd %sm (raw %sm)\t-\n' \
    "$case" "$n" "$rmse" "$p95" "$max" "$std" "$raw"
done

for spec in up_kapitol:45 down_kapitol:-45 up_b5:33 down_b5:-33; do
  name=${spec%%:*} truth=${spec#*:}
  case=changing_altitude/$name
  chain "$name" "$m/$case.log"
  "$bin/ips-export" "$work/$name.lcm" --out "$work/$name.export" --channels ALTITUDE \
    --format csv >/dev/null 2>"$work/$name.export.txt" ||
    die "$case: ips-export failed: $(tail -1 "$work/$name.export.txt")"
  # tag_id and height_m columns by the header's names.
  read -r n total < <(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) { if ($i == "tag_id") t = i; if ($i ~ /^height_m/) h = i } next }
    $t == "T1" { if (!n++) first = $h; last = $h }
    END { if (n) printf "%d %.3f\n", n, last - first; else print "0 nan" }' "$work/$name.export/ALTITUDE.csv")
  [ "$n" -gt 0 ] || die "$case: no ALTITUDE for T1"
  printf 'baro-loruro\t%s\taltitude\t%s\t-\t-\t-\t-\ttotal %sm vs %sm\t-\n' "$case" "$n" "$total" "$truth"
done
