#!/usr/bin/env bash
# ips-eval's command line on a replayed lab log with ten walkers (T1, T1-2 ... T1-10), checked
# against an independent Python reader of the log (lcm_log.py; pose_t and altitude_t decoded
# here):
#   - rows in natural order of tags (T1, T1-2, ..., T1-10) in the table, the JSON and the report;
#   - --from/--to: exactly the estimates whose utime is in the window are scored, the same window
#     given as seconds from the log's start, as Unix time and as ISO-8601; --to before --from is
#     an error;
#   - --by channel: one row per channel, counts the sums of its tags';
#   - ALTITUDE rows in --json (count: every altitude with truth around it) and in the table;
#   - 2D estimators (STATUS_2D) and series whose z never changes have rmse_v null / "-" and no
#     line in the report's height figure;
#   - --dwell: a file (epoch ms, cm, header) with one interval equals --static-point over that
#     interval; estimates outside are counted; the same on the log without TRUTH; a file whose
#     intervals have no length or miss the log is a warning;
#   - dwell-file errors: one line, status 2;
#   - events on an empty channel: counted, skipped, not damage, the same scores.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$HERE/cli_check_lib.sh"  # fail, ok, expect_error; counts failures

"$BIN/ips-sim" --scenario lab --tags 10 --seed 2 --duration 12 --out "$WORK/sim.lcm" --log-level warn
"$BIN/ips-replay" "$WORK/sim.lcm" --out "$WORK/log.lcm" --log-level warn
LOG="$WORK/log.lcm"

# The independent facts: per channel and tag, the utimes and STATUS_2D of the poses, the utimes of
# the altitudes, and the log's first event time.
python3 - "$HERE" "$LOG" "$WORK/facts.json" <<'PY'
import json, struct, sys
sys.path.insert(0, sys.argv[1])
import lcm_log
events, _, _ = lcm_log.events(sys.argv[2])
def string(d, i):
    n = struct.unpack('>i', d[i:i + 4])[0]
    return d[i + 4:i + 4 + n - 1].decode('latin-1'), i + 4 + n
facts = {'start': events[0][1], 'poses': {}, 'altitudes': {}, 'truth': {}}
# pose_t is every message with TRUTH's fingerprint (its first 8 bytes).
pose_fp = next(d[:8] for ch, _, d in events if ch == 'TRUTH')
for ch, ts, d in events:
    if len(d) < 24 or (ch != 'ALTITUDE' and d[:8] != pose_fp):
        continue
    utime = struct.unpack('>q', d[8:16])[0]
    try:
        _, i = string(d, 16)
        tag, i = string(d, i)
    except Exception:
        continue
    if ch == 'ALTITUDE':
        height = struct.unpack('>d', d[i:i + 8])[0]
        facts['altitudes'].setdefault(tag, []).append([utime, height])
    else:
        # position 3 doubles, cov 9, velocity 3, heading 1; num_used i32, residual double, status
        z = struct.unpack('>d', d[i + 16:i + 24])[0]
        status = struct.unpack('>i', d[i + 16 * 8 + 4 + 8:i + 16 * 8 + 4 + 8 + 4])[0]
        if ch == 'TRUTH':
            facts['truth'].setdefault(tag, []).append([utime, z])
        else:
            facts['poses'].setdefault(ch, {}).setdefault(tag, []).append([utime, status, z])
json.dump(facts, open(sys.argv[3], 'w'))
PY

"$BIN/ips-eval" --json "$LOG" >"$WORK/all.json"
"$BIN/ips-eval" "$LOG" >"$WORK/all.txt"
start_us=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["start"])' "$WORK/facts.json")
from_unix=$(python3 -c "print('%.6f' % (($start_us + 4000000) / 1e6))")
to_iso=$(python3 -c "import datetime; print(datetime.datetime.fromtimestamp(($start_us + 9500000) / 1e6, datetime.timezone.utc).strftime('%Y-%m-%dT%H:%M:%S.%fZ'))")
"$BIN/ips-eval" --json "$LOG" --from 4 --to 9.5 >"$WORK/window.json"
"$BIN/ips-eval" --json "$LOG" --from "$from_unix" --to "$to_iso" >"$WORK/window_abs.json"
"$BIN/ips-eval" "$LOG" --from 4 --to 9.5 >"$WORK/window.txt"
"$BIN/ips-eval" --json "$LOG" --by channel >"$WORK/channel.json"
"$BIN/ips-eval" "$LOG" --by channel >"$WORK/channel.txt"
"$BIN/ips-eval" "$LOG" --report "$WORK/report" >/dev/null

# The dwell file: one interval, 4 s to 9.5 s of the log (to the ms), at (5, 4) m, in epoch ms
# and cm; --static-point over the same interval, given as Unix seconds, must score the same.
read -r dwell_from dwell_to < <(python3 - "$start_us" "$WORK/dwell.csv" <<'PY'
import sys
s = int(sys.argv[1])
a, b = (s + 4000000) // 1000, (s + 9500000) // 1000
open(sys.argv[2], 'w').write(f'StartTimestamp,EndTimestamp,X,Y\n{a},{b},500,400\n')
print(f'{a / 1000:.3f} {b / 1000:.3f}')
PY
)
"$BIN/ips-eval" --json "$LOG" --dwell "$WORK/dwell.csv" --dwell-unit cm >"$WORK/dwell.json"
"$BIN/ips-eval" "$LOG" --dwell "$WORK/dwell.csv" --dwell-unit cm >"$WORK/dwell.txt"
"$BIN/ips-eval" --json "$LOG" --static-point 5,4 --from "$dwell_from" --to "$dwell_to" \
  >"$WORK/static_window.json"
# The same log without TRUTH.
python3 - "$LOG" "$WORK/no_truth.lcm" <<'PY'
import struct, sys
data, out, i = open(sys.argv[1], 'rb').read(), bytearray(), 0
while i + 28 <= len(data):
    magic, _, _, cl, dl = struct.unpack('>IqqII', data[i:i + 28])
    if data[i + 28:i + 28 + cl] != b'TRUTH':
        out += data[i:i + 28 + cl + dl]
    i += 28 + cl + dl
open(sys.argv[2], 'wb').write(out)
PY
"$BIN/ips-eval" --json "$WORK/no_truth.lcm" --dwell "$WORK/dwell.csv" --dwell-unit cm \
  >"$WORK/dwell_no_truth.json" 2>"$WORK/dwell_no_truth.err"

if out=$(python3 - "$WORK" <<'PY'
import json, re, sys
w = sys.argv[1]
facts = json.load(open(f'{w}/facts.json'))
load = lambda n: json.load(open(f'{w}/{n}'))
errors = []
def check(cond, what):
    if not cond:
        errors.append(what)

def natural(s):
    return [int(p) if p.isdigit() else p for p in re.split(r'(\d+)', s)]

all_rows = load('all.json')['rows']
tags = ['T1'] + [f'T1-{k}' for k in range(2, 11)]
# Natural order: per channel, the tags T1, T1-2, ..., T1-10.
for ch in sorted({r['channel'] for r in all_rows}):
    got = [r['tag'] for r in all_rows if r['channel'] == ch]
    check(got == sorted(got, key=natural), f'{ch}: tags in order {got}')
check([r['tag'] for r in all_rows if r['channel'] == 'POSE_UWB'] == tags,
      f'POSE_UWB tags {[r["tag"] for r in all_rows if r["channel"] == "POSE_UWB"]}')
txt_tags = [l.split()[1] for l in open(f'{w}/all.txt') if l.startswith('POSE_UWB ')]
check(txt_tags == tags, f'table POSE_UWB tags {txt_tags}')
page = open(f'{w}/report/index.html').read()
pos = [page.find(f'<td>{t}</td>') for t in tags]
check(all(p > 0 for p in pos) and pos == sorted(pos), f'report tag order {pos}')

# Window: exactly the poses with start + 4 s <= utime <= start + 9.5 s.
lo, hi = facts['start'] + 4_000_000, facts['start'] + 9_500_000
win = load('window.json')
check(win == load('window_abs.json'), 'window as Unix time / ISO-8601 differs from seconds')
total_poses = sum(len(v) for ch in facts['poses'].values() for v in ch.values())
total_alt = sum(len(v) for v in facts['altitudes'].values())
inside = 0
for r in win['rows']:
    want = sum(1 for u, *_ in facts['poses'][r['channel']][r['tag']] if lo <= u <= hi)
    inside += want
    full = next(a for a in all_rows if a['channel'] == r['channel'] and a['tag'] == r['tag'])
    check(r['count'] + r['non_finite'] == want and r['count'] < full['count'],
          f'window {r["channel"]}/{r["tag"]}: {r["count"]} scored, {want} in the window, {full["count"]} in all')
alt_inside = sum(1 for v in facts['altitudes'].values() for u, _ in v if lo <= u <= hi)
check(win['window']['outside'] == total_poses + total_alt - inside - alt_inside,
      f'window outside {win["window"]["outside"]}, expected {total_poses + total_alt - inside - alt_inside}')
check(win['window']['from_utime'] == lo and win['window']['to_utime'] == hi, f'window {win["window"]}')
wtxt = open(f'{w}/window.txt').read()
check(re.search(r'\(window from \S+ \(4\.000 s\) to \S+ \(9\.500 s\)', wtxt) is not None, f'window line: {wtxt[-300:]}')

# --by channel: one row per channel, the counts summed over its tags.
ch_rows = load('channel.json')['rows']
check(load('channel.json')['by'] == 'channel', 'by is not channel')
check(len(ch_rows) == len({r['channel'] for r in all_rows}), f'{len(ch_rows)} channel rows')
for r in ch_rows:
    per_tag = [a for a in all_rows if a['channel'] == r['channel']]
    check(r['tag'] is None and r['tags'] == len(per_tag), f'{r["channel"]}: tag {r["tag"]}, tags {r.get("tags")}')
    check(r['count'] == sum(a['count'] for a in per_tag), f'{r["channel"]}: count {r["count"]}')
    if r['count']:
        rmse = (sum(a['rmse_h'] ** 2 * a['count'] for a in per_tag) / r['count']) ** 0.5
        check(abs(r['rmse_h'] - rmse) < 1e-5, f'{r["channel"]}: pooled rmse_h {r["rmse_h"]}, from tags {rmse}')
ctxt = [l.split() for l in open(f'{w}/channel.txt') if l.startswith('POSE_')]
check(ctxt and all(l[1] == '*' for l in ctxt), f'--by channel table tags {[l[1] for l in ctxt]}')

# ALTITUDE rows: one per tag, every altitude with truth around it scored, finite numbers.
alt = load('all.json')['altitude']
check([a['tag'] for a in alt] == tags and all(a['channel'] == 'ALTITUDE' for a in alt),
      f'altitude rows {[(a["channel"], a["tag"]) for a in alt]}')
import bisect
for a in alt:
    # The errors, from truth's z interpolated here (truth within 1 s on both sides).
    tr = sorted(facts['truth'][a['tag']])
    times = [u for u, _ in tr]
    errs = []
    for u, h in facts['altitudes'][a['tag']]:
        k = bisect.bisect_left(times, u)
        if k < len(times) and times[k] == u:
            errs.append(h - tr[k][1])
        elif 0 < k < len(times) and times[k] - times[k - 1] <= 1_000_000:
            f = (u - times[k - 1]) / (times[k] - times[k - 1])
            errs.append(h - (tr[k - 1][1] + f * (tr[k][1] - tr[k - 1][1])))
    n = len(errs)
    check(a['count'] == n and n > 0, f'ALTITUDE/{a["tag"]}: {a["count"]} scored, {n} with truth')
    if n:
        bias, rmse = sum(errs) / n, (sum(e * e for e in errs) / n) ** 0.5
        mx = max(abs(e) for e in errs)
        check(abs(a['bias_v'] - bias) < 2e-6 and abs(a['rmse_v'] - rmse) < 2e-6 and abs(a['max_v'] - mx) < 2e-6,
              f'ALTITUDE/{a["tag"]}: {a}, expected bias {bias:.6f} rmse {rmse:.6f} max {mx:.6f}')
        check(a['p95_v'] <= a['max_v'] + 1e-9, f'ALTITUDE/{a["tag"]}: p95 above max')
    check(a['floor_share'] is None, 'floor_share without floors in the site')
atxt = [l.split() for l in open(f'{w}/all.txt') if l.startswith('ALTITUDE ')]
check(len(atxt) == len(alt) and all(l[-1] == '-' for l in atxt), f'table ALTITUDE rows {atxt[:2]}')

# 2D estimators: rmse_v null exactly where every pose of the row has STATUS_2D, or the row's
# other poses all have one z (a fixed height, as the sim's INS module has).
for r in all_rows:
    poses = facts['poses'][r['channel']][r['tag']]
    planar = all(s & 8 for _, s, _ in poses)
    heights = {z for _, s, z in poses if not s & 8 and z == z}
    fixed = len(heights) == 1 and sum(1 for _, s, z in poses if not s & 8 and z == z) >= 2
    check((r['rmse_v'] is None) == (planar or fixed or r['count'] == 0),
          f'{r["channel"]}/{r["tag"]}: rmse_v {r["rmse_v"]}, all 2D: {planar}, one z: {fixed}')
planar_rows = {(r['channel'], r['tag']) for r in all_rows if r['rmse_v'] is None and r['count']}
check(planar_rows, 'no 2D estimator in the lab log to check "-" with')
for l in open(f'{w}/all.txt'):
    f = l.split()
    if f and (f[0], f[1]) in planar_rows and len(f) == 9 and f[2] != '0':
        check(f[8] == '-', f'table row {l.strip()}: rmse_v of a 2D estimator')
# The report's height figure: a line exactly for the rows with a vertical error.
import xml.etree.ElementTree as ET
hs = ET.parse(f'{w}/report/height.svg').getroot()
drawn = {(p.get('data-channel'), p.get('data-tag')) for p in hs.iter('{http://www.w3.org/2000/svg}polyline')
         if p.get('class') == 'height'}
with_height = {(r['channel'], r['tag']) for r in all_rows if r['rmse_v'] is not None}
check(with_height and drawn == with_height, f'height.svg lines {sorted(drawn)}, rows with rmse_v {sorted(with_height)}')

# --dwell: the interval's point, as --static-point over the same window; the rest outside.
dw, st = load('dwell.json'), load('static_window.json')
lo, hi = st['window']['from_utime'], st['window']['to_utime']
inside = sum(1 for ch in facts['poses'].values() for v in ch.values() for u, *_ in v if lo <= u <= hi)
scored = [r for r in dw['rows'] if r['count'] + r['non_finite'] > 0]
check(scored == st['rows'], 'dwell rows differ from --static-point 5,4 over the interval')
check(dw['outside_dwell'] == total_poses - inside, f'outside_dwell {dw["outside_dwell"]}, expected {total_poses - inside}')
dtxt = open(f'{w}/dwell.txt').read()
check(f'{total_poses - inside} estimates outside every dwell interval' in dtxt, 'dwell footer')
check('(dwell mode: 1 intervals' in dtxt and 'times in ms (guessed), lengths x 0.01 m' in dtxt, 'dwell line')
check(load('dwell_no_truth.json')['rows'] == dw['rows'], 'dwell without TRUTH differs')
if errors:
    print('\n'.join(errors))
    sys.exit(1)
print(f'{len(all_rows)} rows, {inside} of {total_poses} poses in the window, {len(alt)} ALTITUDE rows, '
      f'2D: {sorted({c for c, _ in planar_rows})}')
PY
); then
  ok "$out"
else
  fail "$out"
fi
grep -q "warning: no TRUTH" "$WORK/dwell_no_truth.err" && fail "dwell mode warns about missing TRUTH" ||
  ok "dwell mode on a log without TRUTH: no warning about it"
# A dwell file that names its columns wrongly (start and end on one moment), and one whose times
# the log's do not meet: exit 0, a warning for each, not silence.
printf 'End,Start,X,Y\n1577836800000,1577836800000,1,1\n' >"$WORK/zero.csv"
status=0
"$BIN/ips-eval" "$LOG" --dwell "$WORK/zero.csv" >/dev/null 2>"$WORK/err" || status=$?
if [ "$status" -eq 0 ] && grep -q "^ips-eval: warning: --dwell: .*zero.csv: 1 of 1 intervals have no length" "$WORK/err" &&
  grep -q "^ips-eval: warning: no estimate is inside a dwell interval of .*zero.csv" "$WORK/err"; then
  ok "dwell file that does not meet the log: $(tr '\n' ' ' <"$WORK/err")"
else
  fail "dwell file that does not meet the log: status $status, $(cat "$WORK/err")"
fi

expect_error 2 "^ips-eval: error: --to 3 is before --from 5$" "$BIN/ips-eval" "$LOG" --from 5 --to 3
expect_error 2 "^ips-eval: error: --from: expected seconds .* got 'noon'" "$BIN/ips-eval" "$LOG" --from noon
expect_error 2 "^ips-eval: error: --by: " "$BIN/ips-eval" "$LOG" --by anchor
printf 'start,end,x,y\n0,10,1,1\n' >"$WORK/relative.csv"
expect_error 2 "^ips-eval: error: --dwell: .*relative.csv: 0 messages .*--dwell-time-unit" \
  "$BIN/ips-eval" "$LOG" --dwell "$WORK/relative.csv"
expect_error 2 "^ips-eval: error: --dwell: cannot read '/nonexistent.csv'" \
  "$BIN/ips-eval" "$LOG" --dwell /nonexistent.csv
expect_error 2 "^ips-eval: error: --dwell-unit: expected a length unit" \
  "$BIN/ips-eval" "$LOG" --dwell "$WORK/dwell.csv" --dwell-unit furlong
expect_error 2 "^ips-eval: error: --dwell excludes --static-point" \
  "$BIN/ips-eval" "$LOG" --dwell "$WORK/dwell.csv" --static-point 1,1
expect_error 2 "^ips-eval: error: --dwell-columns, --dwell-time-unit and --dwell-unit need --dwell" \
  "$BIN/ips-eval" "$LOG" --dwell-unit cm

# Events on an empty channel are legal LCM events: counted and skipped, not damage; the scores
# are those of the log without them.
python3 - "$LOG" "$WORK/empty_channel.lcm" <<'PY'
import struct, sys
data = open(sys.argv[1], 'rb').read()
ev = lambda k: struct.pack('>IqqII', 0xEDA1DA01, 900000 + k, 0, 0, k) + bytes(k)
open(sys.argv[2], 'wb').write(ev(0) + data + ev(1) + ev(8))
PY
status=0
"$BIN/ips-eval" --json "$WORK/empty_channel.lcm" >"$WORK/empty_channel.json" 2>"$WORK/err" || status=$?
if [ "$status" -eq 0 ] && [ "$(cat "$WORK/err")" = \
  "ips-eval: $WORK/empty_channel.lcm: 3 events on an empty channel, skipped (legal in LCM; no channel to read them by)" ] &&
  cmp -s "$WORK/all.json" "$WORK/empty_channel.json"; then
  ok "empty channel: $(cat "$WORK/err")"
else
  fail "empty channel: status $status, stderr: $(cat "$WORK/err"), same scores: $(cmp -s "$WORK/all.json" "$WORK/empty_channel.json" && echo yes || echo no)"
fi

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
