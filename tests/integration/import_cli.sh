#!/usr/bin/env bash
# ips-import on small hand-made files: ranges (per-anchor files merged in time order, one file for
# all, libRSF tagged lines, --site-out and --with-site), poses (quaternion + lever arms, dwell
# intervals), a site written into a log (SITE first and every 5 s, read back with ips-export and
# an independent reader of the log format), --into merging two logs, and nothing silent: a
# wrongly separated file and garbage exit 1 with one error line (the hint's text asserted).
set -uo pipefail
BIN=$(cd "$1" && pwd)
export PYTHONPATH=$(cd "$(dirname "$0")" && pwd)  # lcm_log.py
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}
ok() { echo "ok: $*"; }
IMPORT="$BIN/ips-import"

# run STATUS CMD...: runs CMD, checks its exit status; stderr in $WORK/err, stdout in $WORK/out.
run() {
  local want=$1 status=0
  shift
  timeout 60 "$@" >"$WORK/out" 2>"$WORK/err" || status=$?
  if [ "$status" -ne "$want" ]; then
    fail "$* -> status $status (want $want)"
    sed 's/^/  stderr: /' "$WORK/err" | head -10
    return 1
  fi
}

# Prints one line per event: "CHANNEL TIMESTAMP" (the independent reader, lcm_log.py).
events() {
  python3 - "$1" <<'PY'
import sys, lcm_log
evs, n, size = lcm_log.events(sys.argv[1])
assert n == size, f"{n} of {size} bytes read"
for ch, ts, _ in evs:
    print(ch, ts)
PY
}

# --help lists the subcommands.
if run 0 "$IMPORT" --help; then
  for s in ranges poses site; do grep -q "^ *$s " "$WORK/out" || fail "--help does not list $s"; done
  ok "--help lists ranges, poses, site"
fi

# 1. One file per anchor (a ROS dump as uwb-cucudasluv's), merged in time order, with the site.
cat >"$WORK/A1.csv" <<'EOF'
%time,field.stamp,field.id,field.x,field.y,field.z,field.distanceFromTag,field.rssi,field.rssi_fp
1700000000100000000,1700000000099000000,1,0.0,0.0,2.0,5.0,-80.5,-81.0
1700000000300000000,1700000000299000000,1,0.0,0.0,2.0,5.1,-80.0,-81.5
1700000000500000000,1700000000499000000,1,0.0,0.0,2.0,5.2,-79.0,-80.0
EOF
cat >"$WORK/A2.csv" <<'EOF'
%time,field.stamp,field.id,field.x,field.y,field.z,field.distanceFromTag,field.rssi,field.rssi_fp
1700000000200000000,1700000000199000000,2,10.0,0.0,2.0,6.0,-82.0,-83.0
1700000000400000000,1700000000399000000,2,10.0,0.0,2.0,6.1,-82.0,-83.0
EOF
if run 0 "$IMPORT" ranges "$WORK/A1.csv" "$WORK/A2.csv" --tag T1 --with-site \
     --site-out "$WORK/site.yaml" --out "$WORK/r.lcm"; then
  got=$(events "$WORK/r.lcm" | awk '{ printf "%s:%s ", $1, substr($2, 11) }')
  want="SITE:100000 UWB_RANGE:100000 UWB_RANGE:200000 UWB_RANGE:300000 UWB_RANGE:400000 UWB_RANGE:500000 "
  [ "$got" = "$want" ] && ok "two per-anchor files merged in time order, SITE first" || fail "order: $got"
  grep -q "A1.csv: 3 rows, 3 ranges, 0 rejected; columns t,-,anchor,ax,ay,az,range,rx,fp; time ns" "$WORK/err" ||
    fail "summary: $(cat "$WORK/err")"
  grep -q '{id: "1", kind: uwb, position: \[0.0, 0.0, 2.0\]}' "$WORK/site.yaml" &&
    grep -q '{id: "2", kind: uwb, position: \[10.0, 0.0, 2.0\]}' "$WORK/site.yaml" &&
    grep -q '{id: "T1"}' "$WORK/site.yaml" && ok "--site-out: $(grep -c 'kind: uwb' "$WORK/site.yaml") anchors" ||
    fail "--site-out: $(cat "$WORK/site.yaml")"
  if run 0 "$BIN/ips-export" "$WORK/r.lcm" --out "$WORK/r" --format csv; then
    line=$(sed -n 2p "$WORK/r/UWB_RANGE.csv")
    [ "$line" = "1700000000100000,ips-import:A1.csv,T1,1,5.000000,-80.500000,-81.000000,nan,0" ] ||
      [[ "$line" == 1700000000100000,ips-import:A1.csv,T1,1,5*,-80.5*,-81*,*,0 ]] &&
      ok "uwb_range_t fields: $line" || fail "first range: $line"
  fi
fi

# 2. One file for all (tag and anchor columns, no header, cm), and rows with errors counted.
printf '1700000000.0,T1,A1,250\n1700000000.1,T1,A2,310\n1700000000.2,T2,A1,abc\n1700000000.3,T2,A2,290\n' >"$WORK/all.csv"
if run 0 "$IMPORT" ranges "$WORK/all.csv" --unit cm --out "$WORK/all.lcm"; then
  [ "$(events "$WORK/all.lcm" | grep -c UWB_RANGE)" -eq 3 ] && ok "one file for all: 3 ranges" ||
    fail "one file for all: $(events "$WORK/all.lcm")"
  grep -q "all.csv: 3 rows, 3 ranges, 1 rejected (first: line 3: range 'abc' is not a number)" "$WORK/err" &&
    ok "the rejected row is named" || fail "summary: $(cat "$WORK/err")"
fi

# 3. libRSF tagged lines: range2 t range var anchorX anchorY anchorID snr, between other lines.
cat >"$WORK/rsf.txt" <<'EOF'
range2 0.127943992614746 2.95522014829822 0.01 -0.02 -0.01 105 0
odom2diff 0.13 0.1 0.1 0 0.5 0 0 0.01 0.01 0.01
range2 0.255912780761719 1.60500394277233 0.01 -0.02 2.365 107 0
range2 0.383954286575317 0.893085013229014 0.01 2.385 2.36 108 0
EOF
if run 0 "$IMPORT" ranges "$WORK/rsf.txt" --row-tag range2 --columns -,t,range,-,ax,ay,anchor \
     --tag R1 --site-out "$WORK/rsf.yaml" --file-start 2020-01-01T00:00:00Z --out "$WORK/rsf.lcm"; then
  got=$(events "$WORK/rsf.lcm" | awk '{ printf "%s ", $2 }')
  [ "$got" = "1577836800000000 1577836800127969 1577836800256010 " ] && ok "libRSF range2 lines placed by --file-start" ||
    fail "libRSF times: $got"
  grep -q 'height_m: 0.0' "$WORK/rsf.yaml" && grep -q '{id: "108", kind: uwb, position: \[2.385, 2.36, 0.0\]}' "$WORK/rsf.yaml" &&
    ok "planar anchors: the tag gets height 0" || fail "rsf site: $(cat "$WORK/rsf.yaml")"
fi

# 4. Poses: a rigid body with a quaternion and two tags on lever arms -> TRUTH of each tag.
cat >"$WORK/body.csv" <<'EOF'
time,x,y,z,qw,qx,qy,qz
1700000000.0,1,2,1,0.7071067811865476,0,0,0.7071067811865476
1700000000.1,1,2.1,1,0.7071067811865476,0,0,0.7071067811865476
EOF
if run 0 "$IMPORT" poses "$WORK/body.csv" --channel TRUTH --lever-arm TL=0,0.5,0 \
     --lever-arm TR=0,-0.5,0 --out "$WORK/p.lcm"; then
  if run 0 "$BIN/ips-export" "$WORK/p.lcm" --out "$WORK/p" --format csv; then
    python3 - "$WORK/p/TRUTH.csv" <<'PY' && ok "lever arms: TL at x 0.5, TR at x 1.5, heading 90 deg" || fail "lever arms: $(cat "$WORK/p/TRUTH.csv")"
import csv, sys, math
rows = list(csv.DictReader(open(sys.argv[1])))
assert len(rows) == 4, rows
tl = [r for r in rows if r['tag_id'] == 'TL']
tr = [r for r in rows if r['tag_id'] == 'TR']
assert abs(float(tl[0]['position_x_m']) - 0.5) < 1e-9 and abs(float(tr[0]['position_x_m']) - 1.5) < 1e-9
assert abs(float(tr[1]['position_y_m']) - 2.1) < 1e-9
assert abs(float(tl[0]['heading_rad']) - math.pi / 2) < 1e-9
assert tl[0]['source'] == 'truth'
PY
  fi
fi
expect_one_error() {  # STATUS TEXT CMD...: exit STATUS, one stderr line "ips-import: error: ...TEXT..."
  local want=$1 text=$2 status=0 err
  shift 2
  err=$("$@" 2>&1 >/dev/null) || status=$?
  [ "$status" -eq "$want" ] || { fail "$*: status $status (want $want): $err"; return; }
  [ "$(printf '%s\n' "$err" | wc -l)" -eq 1 ] || { fail "$*: more than one line: $err"; return; }
  printf '%s\n' "$err" | grep -q '^ips-import: error: ' && printf '%s\n' "$err" | grep -qF -- "$text" &&
    ok "$err" || fail "$*: '$err' does not say '$text'"
}
printf 'time,x,y\n1700000000,1,2\n' >"$WORK/flat.csv"
expect_one_error 1 "--lever-arm needs the body's orientation" \
  "$IMPORT" poses "$WORK/flat.csv" --channel TRUTH --lever-arm T1=0,0,0 --out "$WORK/x.lcm"

# 5. Dwell intervals (ips-eval --dwell's format, cm) -> TRUTH at 10 Hz through each interval.
printf 'StartTimestamp,EndTimestamp,X,Y\n1700000000000,1700000001000,100,200\n1700000005000,1700000005500,300,200\n' >"$WORK/dwell.csv"
if run 0 "$IMPORT" poses "$WORK/dwell.csv" --dwell --unit cm --tag T1 --channel TRUTH --out "$WORK/d.lcm"; then
  [ "$(events "$WORK/d.lcm" | grep -c TRUTH)" -eq 17 ] && ok "dwell: 11 + 6 poses at 10 Hz" ||
    fail "dwell: $(events "$WORK/d.lcm" | wc -l) events"
fi

expect_one_error 2 "--dwell reads start and end times from the file" \
  "$IMPORT" poses "$WORK/dwell.csv" --dwell --rate 10 --tag T1 --channel TRUTH --out "$WORK/x.lcm"

# 6. A site into a log: SITE first and every 5 s by the log's times, in place (temp + rename).
printf 'time,x,y\n' >"$WORK/long.csv"
for i in $(seq 0 120); do printf '17000000%02d.%d,1,2\n' $((i / 10)) $((i % 10)) >>"$WORK/long.csv"; done
cat >"$WORK/lab.yaml" <<'EOF'
name: hand-made
anchors:
  - {id: A1, kind: uwb, position: [0.0, 0.0, 2.4]}
  - {id: A2, kind: uwb, position: [10.0, 0.0, 2.4]}
EOF
if run 0 "$IMPORT" poses "$WORK/long.csv" --tag T1 --channel TRUTH --out "$WORK/long.lcm" &&
   run 0 "$IMPORT" site "$WORK/lab.yaml" --into "$WORK/long.lcm"; then
  got=$(events "$WORK/long.lcm" | awk '$1 == "SITE" { printf "%d ", NR }')
  [ "$got" = "1 52 103 " ] && ok "SITE at the head and every 5 s: events $got" || fail "SITE positions: $got"
  ls "$WORK" | grep -q 'tmp$' && fail "a temp file was left"
  if run 0 "$BIN/ips-export" "$WORK/long.lcm" --out "$WORK/long" --format csv --channels SITE; then
    grep -q 'hand-made' "$WORK/long/SITE.csv" && ok "ips-export reads the SITE back" || fail "SITE.csv: $(head -3 "$WORK/long/SITE.csv")"
  fi
  # Again, to a new log: the old SITEs are replaced, not doubled.
  run 0 "$IMPORT" site "$WORK/lab.yaml" --into "$WORK/long.lcm" --every 0 --out "$WORK/long2.lcm" &&
    [ "$(events "$WORK/long2.lcm" | grep -c SITE)" -eq 1 ] && ok "site --every 0 --out: one SITE, old ones replaced" ||
    fail "site again: $(events "$WORK/long2.lcm" | grep -c SITE) SITE"
fi

# 7. --into merges a new import into an existing log (ranges + truth in one log).
if run 0 "$IMPORT" poses "$WORK/body.csv" --channel TRUTH --lever-arm T1=0,0,0 --into "$WORK/r.lcm" --out "$WORK/rt.lcm"; then
  got=$(events "$WORK/rt.lcm" | awk '{ printf "%s ", $1 }')
  [ "$got" = "SITE TRUTH SITE UWB_RANGE TRUTH UWB_RANGE UWB_RANGE UWB_RANGE UWB_RANGE " ] &&
    ok "--into: merged in time order, the log's SITE repeated at the new head" || fail "--into: $got"
fi

# 8. Nothing silent: a wrongly separated file, garbage, an empty file, a missing tag.
expect_one_error 1 "looks comma-separated: try --separator ," \
  "$IMPORT" ranges "$WORK/all.csv" --separator ';' --out "$WORK/x.lcm"
python3 "$PYTHONPATH/lcm_log.py" garbage 3000 >"$WORK/garbage.bin"
expect_one_error 1 "garbage.bin" "$IMPORT" ranges "$WORK/garbage.bin" --out "$WORK/x.lcm"
: >"$WORK/empty.csv"
expect_one_error 1 "empty.csv: no range (an empty file)" "$IMPORT" ranges "$WORK/empty.csv" --out "$WORK/x.lcm"
expect_one_error 1 "no tag column (columns t,-,anchor,ax,ay,az,range,rx,fp); give --tag T for a file of one tag" "$IMPORT" ranges "$WORK/A1.csv" --out "$WORK/x.lcm"
expect_one_error 2 "cannot read" "$IMPORT" ranges "$WORK/nope.csv" --out "$WORK/x.lcm"
# (after the file's summary line) the error as the last line, status 2
status=0
"$IMPORT" ranges "$WORK/all.csv" --with-site --out "$WORK/x.lcm" 2>"$WORK/err" || status=$?
[ "$status" -eq 2 ] && tail -1 "$WORK/err" | grep -qF "ips-import: error: --with-site/--site-out need the anchors' positions in the rows" &&
  ok "--with-site without positions: $(tail -1 "$WORK/err")" || fail "--with-site without positions: $status $(cat "$WORK/err")"
[ ! -e "$WORK/x.lcm" ] && ok "no log written by a failed import" || fail "a failed import wrote x.lcm"

[ "$failures" -eq 0 ] && echo "import_cli: all passed" || echo "import_cli: $failures failures"
[ "$failures" -eq 0 ]
