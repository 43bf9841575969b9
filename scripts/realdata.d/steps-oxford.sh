#!/usr/bin/env bash
# steps-oxford (Oxford step counter DataSet, optimisation split: 18 traces, CC BY 4.0): a phone's
# accelerometer only (t_ns since boot, accuracy, ax, ay, az; m/s^2; about 50 to 100 Hz), carried
# in 7 positions; the truth is the step total of each trace (stats.csv). Per trace:
#   ips-phone-imu --file <trace>/accelerometer.csv --columns t,-,ax,ay,az --time-unit ns \
#     --out trace.lcm
#   ips-replay trace.lcm --only pdr --site site.yaml --out trace-replay.lcm
#   ips-export trace-replay.lcm --channels STEP --format csv --out trace-steps
# and the STEP messages are counted against stats.csv's steps. site.yaml is the smallest site
# (no anchors; ips-pdr's defaults). The times since boot are kept as they are (no --file-start:
# only their spacing matters to a step counter). One row per trace (other: signed count error,
# estimated against counted), then one per carrying position and one over all traces (other:
# the mean absolute count error and the worst trace's). The phones have no gyroscope: ips-pdr
# counts steps on the accelerometer alone and publishes them with the heading unknown (NaN).
# When ips-pdr makes no estimate at all, ips-replay says why on stderr and the trace counts 0
# steps: the rows stay honest (-100 %).
# Usage: steps-oxford.sh <realdata-folder> <work-dir> <bin-dir>
set -euo pipefail
DATA=$1 WORK=$2 BIN=$3
mkdir -p "$WORK"
STATS="$DATA/stats.csv"
[ -f "$STATS" ] || { echo "steps-oxford: no stats.csv in $DATA" >&2; exit 1; }
[ -d "$DATA/optimisation/data" ] || { echo "steps-oxford: no optimisation/data in $DATA" >&2; exit 1; }
run() {
  echo "+ $*" >&2
  "$@" >&2 || { echo "steps-oxford: failed: $(basename "$1") ${2:-} (status $?)" >&2; exit 1; }
}
printf 'name: steps-oxford\nanchors: []\n' >"$WORK/site.yaml"
: >"$WORK/counts.tsv"
traces=0
for dir in "$DATA"/optimisation/data/*/; do
  name=$(basename "$dir")
  [ -f "$dir/accelerometer.csv" ] || continue
  traces=$((traces + 1))
  w="$WORK/$name"
  run "$BIN/ips-phone-imu" --file "$dir/accelerometer.csv" --columns t,-,ax,ay,az --time-unit ns \
    --out "$w.lcm"
  echo "+ $BIN/ips-replay $w.lcm --only pdr --site $WORK/site.yaml --out $w-replay.lcm" >&2
  rc=0
  "$BIN/ips-replay" "$w.lcm" --only pdr --site "$WORK/site.yaml" --out "$w-replay.lcm" \
    2>"$w-replay.err" || rc=$?
  cat "$w-replay.err" >&2
  steps=0
  if [ "$rc" -eq 0 ]; then
    run "$BIN/ips-export" "$w-replay.lcm" --channels STEP --format csv --out "$w-steps"
    if [ -f "$w-steps/STEP.csv" ]; then
      steps=$(($(wc -l <"$w-steps/STEP.csv") - 1))
    fi
  elif grep -q "no hosted estimator gave an estimate" "$w-replay.err"; then
    echo "steps-oxford: $name: ips-pdr made no estimate: $(grep -m1 'pdr:' "$w-replay.err" |
      sed 's/.*pdr: /pdr: /')" >&2
  else
    echo "steps-oxford: failed: ips-replay $name (status $rc)" >&2
    exit 1
  fi
  printf '%s\t%s\n' "$name" "$steps" >>"$WORK/counts.tsv"
done
[ "$traces" -gt 0 ] || { echo "steps-oxford: no trace with accelerometer.csv" >&2; exit 1; }
python3 - "$STATS" "$WORK/counts.tsv" <<'PY'
import sys
truth, position = {}, {}
for line in open(sys.argv[1]):
    if line.startswith("#") or not line.strip():
        continue
    f = [x.strip() for x in line.split(",")]
    truth[f[0]], position[f[0]] = int(f[6]), f[3]
rows, groups = [], {}
for line in open(sys.argv[2]):
    name, steps = line.split("\t")
    steps = int(steps)
    if name not in truth:
        sys.exit(f"steps-oxford: {name} is not in stats.csv")
    err = 100.0 * (steps - truth[name]) / truth[name]
    print("\t".join(["steps-oxford", name, "pdr", str(steps), "-", "-", "-", "-",
                     "%+.1f%%" % err, "-"]))
    groups.setdefault(position[name].lower(), []).append(abs(err))
    rows.append(abs(err))
for pos in sorted(groups):
    e = groups[pos]
    name = next(p for n, p in position.items() if p.lower() == pos)
    print("\t".join(["steps-oxford", "position " + name, "pdr", str(len(e)), "-", "-", "-", "-",
                     "mean |err| %.1f%%, worst %.1f%%" % (sum(e) / len(e), max(e)), "-"]))
print("\t".join(["steps-oxford", "all", "pdr", str(len(rows)), "-", "-", "-", "-",
                 "mean |err| %.1f%%, worst %.1f%%" % (sum(rows) / len(rows), max(rows)), "-"]))
PY
