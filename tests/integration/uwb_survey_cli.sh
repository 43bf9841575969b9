#!/usr/bin/env bash
# ips-uwb-survey on real files: a simulated lab log (30 s, anchor pairs at 1 Hz) surveyed into a
# site file whose anchors are within 0.10 m of the scenario's and which loads again; --force;
# the mirror decided by a known point (tag standing at its start point, anchor order A2, A1, A3);
# and the error paths: one clear line, status 2 for usage and configuration, 1 when the data
# cannot give a survey.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
export PYTHONPATH=$(cd "$(dirname "$0")" && pwd)  # lcm_log.py
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"  # fail, ok, run, expect_error; counts failures
RUN_STDOUT_LINES=20  # run prints this much of stdout on a wrong status
SURVEY="$BIN/ips-uwb-survey"

# positions FILE: "ID X Y Z" for each anchor of a site file written by ips-uwb-survey (flow
# style, as the lab's), without a YAML library.
positions() {
  python3 - "$1" <<'PY'
import re, sys
for m in re.finditer(r'\{id: (\w+),[^}]*position: \[([^\]]*)\]', open(sys.argv[1]).read()):
    print(m.group(1), *[float(v) for v in m.group(2).split(',')])
PY
}

# within FILE WANT TOL: every anchor of WANT ("ID X Y Z;...") within TOL m of FILE's.
within() {
  python3 - "$1" "$2" "$3" <<'PY'
import math, re, sys
got = {}
for m in re.finditer(r'\{id: (\w+),[^}]*position: \[([^\]]*)\]', open(sys.argv[1]).read()):
    got[m.group(1)] = [float(v) for v in m.group(2).split(',')]
worst = 0
for item in sys.argv[2].split(';'):
    i, *p = item.split()
    p = [float(v) for v in p]
    err = math.dist(got[i], p)
    print(f'{i} {err:.3f}', end='  ')
    worst = max(worst, err)
print()
sys.exit(0 if worst <= float(sys.argv[3]) else 1)
PY
}

LAB_TRUTH="A1 0 0 2.4;A2 10 0 2.4;A3 10 8 2.4;A4 0 8 2.4"

"$BIN/ips-sim" --scenario lab --seed 1 --duration 30 --out "$WORK/lab.lcm" --log-level warn || exit 1

# 1. The survey of the lab log: the written site has every anchor within 0.10 m, heights kept,
#    the other anchors and fields untouched.
if run 0 "$SURVEY" --log "$WORK/lab.lcm" --out "$WORK/site.yaml"; then
  cat "$WORK/out"
  grep -q "180 between anchors" "$WORK/out" && ok "180 anchor-pair ranges read (6 pairs, 1 Hz, 30 s)" ||
    fail "pair range count: $(head -1 "$WORK/out")"
  for pair in A1-A2 A1-A3 A1-A4 A2-A3 A2-A4 A3-A4; do
    grep -Eq "^$pair +30 " "$WORK/out" || fail "pair $pair: not 30 samples"
  done
  grep -q "put at +y by convention" "$WORK/out" && ok "no known point: +y convention said" ||
    fail "no mirror line"
  grep -q "^note:" "$WORK/out" && fail "lab frame = survey frame, yet: $(grep '^note:' "$WORK/out")"
  if errs=$(within "$WORK/site.yaml" "$LAB_TRUTH" 0.10); then ok "written site within 0.10 m: $errs"; else fail "written site: $errs"; fi
  head -1 "$WORK/site.yaml" | grep -q "^# Surveyed by ips-uwb-survey from .*lab.lcm: 6 anchor pairs" &&
    ok "header comment" || fail "header: $(head -1 "$WORK/site.yaml")"
  grep -q "{id: D1, kind: uwb_tdoa, position: \[0.3, 0.3, 2.6\]}" "$WORK/site.yaml" &&
    grep -q "{id: B2, kind: ble_aoa, position: \[10.0, 4.0, 2.2\], orientation_deg: \[0, 0, 180\]}" "$WORK/site.yaml" &&
    grep -q "{id: T1, height_m: 1.2, start_position: \[2.0, 1.5\], start_heading_deg: 0}" "$WORK/site.yaml" && ok "other anchors and tags unchanged" ||
    fail "other anchors or tags changed"
  [ "$(positions "$WORK/site.yaml" | awk '$1 ~ /^A/ { print $4 }' | sort -u)" = "2.4" ] &&
    ok "heights kept" || fail "heights: $(positions "$WORK/site.yaml")"
fi

# The written site loads (our own parser, through --site) and the same data moves no anchor.
if run 0 "$SURVEY" --log "$WORK/lab.lcm" --site "$WORK/site.yaml"; then
  moved=$(awk '$1 ~ /^A[1-4]$/ && NF == 9 { if ($7 > m) m = $7 } END { print m + 0 }' "$WORK/out")
  awk -v m="$moved" 'BEGIN { exit !(m <= 0.001) }' && ok "written site loads; resurvey moves <= $moved m" ||
    fail "resurvey against the written site moved $moved m"
  grep -q "(no --out: nothing written)" "$WORK/out" || fail "no --out: no note"
fi

# --out refuses an existing file, --force overwrites it.
expect_error 2 "^ips-uwb-survey: error: --out: '.*site.yaml' exists \(--force overwrites it\)$" \
  "$SURVEY" --log "$WORK/lab.lcm" --out "$WORK/site.yaml"
echo "old" >"$WORK/old.yaml"
if run 0 "$SURVEY" --log "$WORK/lab.lcm" --out "$WORK/old.yaml" --force; then
  grep -q "^anchors:" "$WORK/old.yaml" && ok "--force overwrote" || fail "--force did not overwrite"
fi

# 2. The mirror: the tag stands at its start point, lab (2, 1.5, 1.2), for the first 10 s. With
#    A2 at the origin and A1 on +x, A3 and A4 are at -y; in that frame the point is (8, -1.5) and
#    the lab point (x, y) is at (10 - x, -y). Z comes from the site's tag height.
sed 's/^    loop: true$/    loop: true\n    start_s: 10/' "$ROOT/config/scenarios/lab.yaml" >"$WORK/lab-start.yaml"
grep -q "start_s: 10" "$WORK/lab-start.yaml" || fail "could not make the standing-start scenario"
"$BIN/ips-sim" --scenario "$WORK/lab-start.yaml" --seed 2 --duration 30 --out "$WORK/start.lcm" --log-level warn || exit 1
MIRROR_TRUTH="A2 0 0 2.4;A1 10 0 2.4;A3 0 -8 2.4;A4 10 -8 2.4"
if run 0 "$SURVEY" --log "$WORK/start.lcm" --order A2,A1,A3 --known-point T1=8,-1.5 \
  --known-window 0,9 --out "$WORK/mirror.yaml"; then
  grep -Eq "^mirror: A3 at -y, chosen by tag T1 at \(8.000, -1.500, 1.200\)" "$WORK/out" &&
    ok "$(grep '^mirror' "$WORK/out")" || fail "mirror line: $(grep '^mirror' "$WORK/out")"
  if errs=$(within "$WORK/mirror.yaml" "$MIRROR_TRUTH" 0.10); then ok "reflected survey within 0.10 m: $errs"; else fail "reflected survey: $errs"; fi
  grep -q "^# Frame: A2 at the origin, A1 on +x, A3 at -y (decided by a known point)." "$WORK/mirror.yaml" ||
    fail "frame comment: $(sed -n 2p "$WORK/mirror.yaml")"
  grep -q "^note: in the input site A2 is not at the origin with A1 on +x" "$WORK/out" &&
    ok "frames differ: noted" || fail "no note that the frames differ"
fi
if run 0 "$SURVEY" --log "$WORK/start.lcm" --order A2,A1,A3 --out "$WORK/conv.yaml"; then
  if errs=$(within "$WORK/conv.yaml" "A2 0 0 2.4;A1 10 0 2.4;A3 0 8 2.4;A4 10 8 2.4" 0.10); then
    ok "without the known point: the +y reflection: $errs"
  else
    fail "without the known point: $errs"
  fi
fi
# The window while the tag walks: it fits worse, which is said.
if run 0 "$SURVEY" --log "$WORK/start.lcm" --order A2,A1,A3 --known-point T1=8,-1.5,1.2 --known-window 12,20; then
  grep -q "warning: the tag's ranges at the known point fit poorly" "$WORK/err" &&
    ok "walking tag in the window: warned" || fail "no warning for a walking tag: $(cat "$WORK/err")"
fi

# 3. Errors.
"$BIN/ips-sim" --scenario lab --duration 2 --out "$WORK/short.lcm" --log-level warn || exit 1
sed 's/anchor_pairs_rate_hz: 1/anchor_pairs_rate_hz: 0/' "$ROOT/config/scenarios/lab.yaml" >"$WORK/nopairs.yaml"
"$BIN/ips-sim" --scenario "$WORK/nopairs.yaml" --duration 5 --out "$WORK/nopairs.lcm" --log-level warn || exit 1
python3 - "$WORK/lab.lcm" "$WORK/nosite.lcm" <<'PY'
import struct, sys, lcm_log
evs, _, _ = lcm_log.events(sys.argv[1])
with open(sys.argv[2], 'wb') as f:
    for n, (ch, ts, data) in enumerate(e for e in evs if e[0] != 'SITE'):
        c = ch.encode('latin-1')
        f.write(struct.pack('>IqqII', lcm_log.MAGIC, n, ts, len(c), len(data)) + c + data)
PY
echo "not a log" >"$WORK/text.txt"
printf 'name: broken\nanchors:\n  - {id: A1, position: [0, 0]}\n' >"$WORK/bad-site.yaml"
expect_error 2 "^ips-uwb-survey: error: give either --log FILE or --duration S" "$SURVEY"
expect_error 2 "^ips-uwb-survey: error: give either --log FILE or --duration S" "$SURVEY" --log "$WORK/lab.lcm" --duration 5
expect_error 2 "^ips-uwb-survey: error: --lcm-url is for live mode" "$SURVEY" --log "$WORK/lab.lcm" --lcm-url memq://
expect_error 2 "^ips-uwb-survey: error: cannot read log '.*missing.lcm'" "$SURVEY" --log "$WORK/missing.lcm"
expect_error 2 "^ips-uwb-survey: error: '.*text.txt' is not an LCM log" "$SURVEY" --log "$WORK/text.txt"
expect_error 2 "^ips-uwb-survey: error: no site: .*nosite.lcm has no SITE message; give the site with --site FILE$" \
  "$SURVEY" --log "$WORK/nosite.lcm"
if run 0 "$SURVEY" --log "$WORK/nosite.lcm" --site "$ROOT/config/sites/lab.yaml"; then ok "no SITE in the log, --site given"; fi
expect_error 2 "^ips-uwb-survey: error: anchor order: no anchor 'A7' in the site$" "$SURVEY" --log "$WORK/lab.lcm" --order A1,A2,A7
expect_error 2 "^ips-uwb-survey: error: anchor order: anchor 'D1' is of kind uwb_tdoa, not uwb$" "$SURVEY" --log "$WORK/lab.lcm" --order A1,A2,D1
expect_error 2 "^ips-uwb-survey: error: anchor order: give at least 3 anchors" "$SURVEY" --log "$WORK/lab.lcm" --order A1,A2
expect_error 2 "^ips-uwb-survey: error: --known-point: expected TAG=X,Y or TAG=X,Y,Z in metres, got 'T1=1'$" \
  "$SURVEY" --log "$WORK/lab.lcm" --known-point T1=1
expect_error 2 "^ips-uwb-survey: error: --known-point: give Z \(TAG=X,Y,Z\): the site has no height_m for tag 'T9'$" \
  "$SURVEY" --log "$WORK/lab.lcm" --known-point T9=1,2
expect_error 2 "^ips-uwb-survey: error: --known-window needs --known-point$" "$SURVEY" --log "$WORK/lab.lcm" --known-window 0,5
expect_error 2 "^ips-uwb-survey: error: --known-window: expected START_S,END_S with START_S <= END_S$" \
  "$SURVEY" --log "$WORK/lab.lcm" --known-point T1=2,1.5 --known-window 5,1
expect_error 2 "^ips-uwb-survey: error: --out: no directory '.*/nodir'$" "$SURVEY" --log "$WORK/lab.lcm" --out "$WORK/nodir/site.yaml"
expect_error 2 "^ips-uwb-survey: error: --min-samples: expected at least 1$" "$SURVEY" --log "$WORK/lab.lcm" --min-samples 0
expect_error 2 "^ips-uwb-survey: error: .*bad-site.yaml" "$SURVEY" --log "$WORK/lab.lcm" --site "$WORK/bad-site.yaml"
expect_error 1 "^ips-uwb-survey: error: survey failed: pair A1-A2: no ranges \(needed to place A2 on \+x\)$" \
  "$SURVEY" --log "$WORK/nopairs.lcm"
expect_error 1 "^ips-uwb-survey: error: survey failed: pair A1-A2: 2 ranges, fewer than the 10 required" \
  "$SURVEY" --log "$WORK/short.lcm" --out "$WORK/never.yaml"
[ ! -e "$WORK/never.yaml" ] && ok "failed survey writes nothing" || fail "failed survey wrote --out"
if run 0 "$SURVEY" --log "$WORK/short.lcm" --min-samples 2; then ok "--min-samples 2 on a 2 s log"; fi
expect_error 1 "^ips-uwb-survey: error: survey failed: known point: tag T1 has ranges to no surveyed anchor" \
  "$SURVEY" --log "$WORK/lab.lcm" --known-point T1=2,1.5 --known-window 100,200
if run 0 "$SURVEY" --help; then
  grep -q -- "--known-point TAG=X,Y\[,Z\]" "$WORK/out" && grep -q -- "--order" "$WORK/out" &&
    ok "--help" || fail "--help lacks options"
fi

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
