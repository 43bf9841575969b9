#!/usr/bin/env bash
# baro-loruro (github.com/loruro/Barometer_STM32, GPL-3.0: read in place, never copied): a BMP180
# (and an MPL115A1) at rest at each oversampling setting (in_place/oss_0..3.log) and carried up
# and down the stairs of two buildings (changing_altitude/{up,down}_{b5,kapitol}.log).
#   scripts/realdata.d/baro-loruro.sh <realdata-folder-path> <work-dir> <bin-dir>
# Each file: ips-baro --file (times: the rows spread evenly between the banner's start and end
# dates, the derived rate printed) -> ips-replay hosting ips-altitude with
# config/sites/realdata/baro-loruro.yaml. The recordings have no reference station: the site
# puts ips-altitude in its single-barometer mode (mode: relative), heights being changes since the
# mean of each sensor's first second. Figures, for the BMP180 (tag T1):
#   at rest: ips-eval --static-point 0,0,0 (truth: no change): N, RMSE, p95, max of the filtered
#            height; other = its standard deviation, the raw per-sample height noise (the
#            BMP180 pressures' standard deviation in m, from ips-baro's summary) and the share of
#            the errors within the reported 2 sigma (cov2s, from ips-export of ALTITUDE);
#   stairs:  the filtered height's change (mean of the last 2 s minus mean of the first second,
#            ips-export of ALTITUDE) against the hypsometric change of the same readings (the
#            BMP180 pressures over the same windows, ips-export of BARO: core/barometric.hpp's
#            equation with the readings' mean temperature, 50 % humidity, g 9.81) and the
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
  echo "+ ips-baro --file $file --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC --out $work/$case.baro.lcm" >&2
  "$bin/ips-baro" --file "$file" --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC \
    --out "$work/$case.baro.lcm" 2>"$work/$case.baro.txt" ||
    die "$case: ips-baro failed: $(tail -1 "$work/$case.baro.txt")"
  sed 's/^/  /' "$work/$case.baro.txt" >&2
  "$bin/ips-export" "$work/$case.baro.lcm" --out "$work/$case.baro.export" --channels BARO \
    --format csv >/dev/null 2>"$work/$case.baro.export.txt" ||
    die "$case: ips-export of BARO failed: $(tail -1 "$work/$case.baro.export.txt")"
  echo "+ ips-replay $work/$case.baro.lcm --only altitude --site $site --out $work/$case.lcm" >&2
  "$bin/ips-replay" "$work/$case.baro.lcm" --only altitude --site "$site" \
    --out "$work/$case.lcm" >"$work/$case.replay.txt" 2>&1 ||
    die "$case: ips-replay failed: $(tail -1 "$work/$case.replay.txt")"
  "$bin/ips-export" "$work/$case.lcm" --out "$work/$case.export" --channels ALTITUDE \
    --format csv >/dev/null 2>"$work/$case.export.txt" ||
    die "$case: ips-export failed: $(tail -1 "$work/$case.export.txt")"
}

# figures DIR: T1's share of |height| within 2 height_std_m (truth: no change), and its
# filtered and hypsometric height changes (last 2 s against the first second), one line.
figures() {
  python3 - "$work/$1" <<'PY'
import csv, math, sys
base = sys.argv[1]
def rows(path, tag_field, tag):
    with open(path, newline="") as f:
        return [r for r in csv.DictReader(f) if r.get(tag_field) == tag]
def col(r, prefix):  # a column by its name's start (the header may carry units)
    for k, v in r.items():
        if k == prefix or k.startswith(prefix + "_") or k.startswith(prefix + " "):
            return float(v)
    raise SystemExit("no column " + prefix)
alt = rows(base + ".export/ALTITUDE.csv", "tag_id", "T1")
baro = rows(base + ".baro.export/BARO.csv", "sensor_id", "T1")
if not alt or not baro: raise SystemExit("no T1 in ALTITUDE or BARO")
t = lambda r: col(r, "utime") * 1e-6
inside = sum(1 for r in alt if abs(col(r, "height_m")) <= 2 * col(r, "height_std_m"))
def windows(rs, value):
    t0, t1 = t(rs[0]), t(rs[-1])
    first = [value(r) for r in rs if t(r) <= t0 + 1.0]
    last = [value(r) for r in rs if t(r) >= t1 - 2.0]
    return sum(first) / len(first), sum(last) / len(last)
h0, h1 = windows(alt, lambda r: col(r, "height_m"))
p0, p1 = windows(baro, lambda r: col(r, "pressure_pa"))
tc = sum(col(r, "temperature_c") for r in baro) / len(baro)
# core/barometric.hpp: virtual temperature at 50 %, g 9.81, R_d = 8.314462618 / 0.0289652.
e = 0.5 * 611.2 * math.exp(17.67 * tc / (tc + 243.5))
tv = (tc + 273.15) / (1 - e / p0 * (1 - 0.018016 / 0.0289652))
hyp = 8.314462618 / 0.0289652 * tv / 9.81 * math.log(p0 / p1)
print("%.3f %.3f %.3f" % (inside / len(alt), h1 - h0, hyp))
PY
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
  read -r cov _ _ < <(figures "oss_$k") || die "$case: no figures"
  printf 'baro-loruro\t%s\taltitude\t%s\t%s\t%s\t-\t%s\tstd %sm (raw %sm), cov2s %s\t-\n' \
    "$case" "$n" "$rmse" "$p95" "$max" "$std" "$raw" "$cov"
done

for spec in up_kapitol:45 down_kapitol:-45 up_b5:33 down_b5:-33; do
  name=${spec%%:*} truth=${spec#*:}
  case=changing_altitude/$name
  chain "$name" "$m/$case.log"
  n=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "tag_id") t = i; next } $t == "T1" { n++ }
    END { print n + 0 }' "$work/$name.export/ALTITUDE.csv")
  [ "$n" -gt 0 ] || die "$case: no ALTITUDE for T1"
  read -r _ total hyp < <(figures "$name") || die "$case: no figures"
  printf 'baro-loruro\t%s\taltitude\t%s\t-\t-\t-\t-\ttotal %sm vs hypsometric %sm (%s%%), assumed %sm\t-\n' \
    "$case" "$n" "$total" "$hyp" "$(python3 -c "print('%+.2f' % (100 * ($total - $hyp) / $hyp))")" "$truth"
done
