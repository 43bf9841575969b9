#!/usr/bin/env bash
# ips-eval --report on a real log (simulated lab, replayed): the four SVG files parse as XML; the
# map has one anchor marker per SITE anchor, at the position ips-export reads from the log; one
# estimator polyline per row of --json in the map and the CDF, in each channel's colour of
# core/channel_colours (POSE_FUSED red, as ips-view draws it); the error-against-time figure draws
# the rows within 5 times the best RMSE and lists the others as off scale with their RMSE; every
# CDF climbs from 0 to 1 in one step per scored estimate, on a log axis when a row is off scale;
# the height figure has a line per row with a vertical error and per ALTITUDE row, none for the 2D
# rows (named in its legend); index.html holds the same figures inline, no script and no external asset, and its first table
# has the --json numbers ("-" heights for 2D rows; ALTITUDE has a table of its own); static-point
# mode; a log without estimates; --json and the table unchanged by --report; an unwritable DIR
# gives one error line and status 2.
set -euo pipefail
BIN=$(cd "$1" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}
ok() { echo "ok: $*"; }

"$BIN/ips-sim" --scenario lab --seed 1 --duration 20 --out "$WORK/sim.lcm" --log-level warn
"$BIN/ips-replay" "$WORK/sim.lcm" --out "$WORK/replayed.lcm" --log-level warn
# A log path with characters HTML must escape: the page still parses and shows it as it is.
LOG="$WORK/lab <a&b>.lcm"
cp "$WORK/replayed.lcm" "$LOG"

"$BIN/ips-eval" --json "$LOG" >"$WORK/plain.json"
"$BIN/ips-eval" "$LOG" >"$WORK/plain.txt"
"$BIN/ips-export" "$LOG" --out "$WORK/export" --channels SITE --format jsonl >/dev/null
status=0
"$BIN/ips-eval" "$LOG" --report "$WORK/report/new" >"$WORK/report.txt" 2>"$WORK/err" || status=$?
if [ "$status" -eq 0 ] && [ -s "$WORK/report/new/index.html" ]; then
  ok "--report wrote $(cd "$WORK/report/new" && ls | tr '\n' ' ')($(stat -c %s "$WORK/report/new/index.html") bytes of index.html)"
else
  fail "--report: status $status, stderr: $(cat "$WORK/err")"
fi
cmp -s "$WORK/plain.txt" "$WORK/report.txt" && ok "table unchanged by --report" ||
  fail "table differs with --report"
status=0
"$BIN/ips-eval" --json "$LOG" --report "$WORK/report/json" >"$WORK/report.json" || status=$?
[ "$status" -eq 0 ] && cmp -s "$WORK/plain.json" "$WORK/report.json" &&
  [ -s "$WORK/report/json/index.html" ] && ok "--json unchanged by --report" ||
  fail "--json with --report: status $status"

# check_report DIR JSON SITE_JSONL LOG_PATH MODE: every check on one report, in Python with the
# standard library only. MODE is "truth" or "static".
check_report() {
  python3 - "$@" <<'PY'
import html.parser, json, re, sys, xml.etree.ElementTree as ET

d, json_path, site_path, log_path, mode = sys.argv[1:6]
NS = '{http://www.w3.org/2000/svg}'
rows = json.load(open(json_path))['rows']
errors = []
def check(cond, what):
    if not cond:
        errors.append(what)

svgs = {}
for name in ('map', 'error_time', 'error_cdf', 'height'):
    try:
        svgs[name] = ET.parse(f'{d}/{name}.svg').getroot()
    except ET.ParseError as e:
        sys.exit(f'{name}.svg does not parse: {e}')
    check(svgs[name].tag == NS + 'svg', f'{name}.svg root is {svgs[name].tag}')

def by_class(root, tag, cls):
    return [e for e in root.iter(NS + tag) if e.get('class') == cls]

def points(poly):
    return [tuple(map(float, p.split(','))) for p in poly.get('points').split()]

def ticks(root, cls, attr):
    # Tick labels: their x (or y) attribute is the pixel of the value they show.
    return [(float(t.text), float(t.get(attr))) for t in by_class(root, 'text', cls)]

def pixel_map(tick_list, log=False):
    (v0, p0), (v1, p1) = tick_list[0], tick_list[-1]
    if log:
        return lambda p: v0 * (v1 / v0) ** ((p - p0) / (p1 - p0))
    return lambda p: v0 + (p - p0) * (v1 - v0) / (p1 - p0)

# Off scale: RMSE over 5 times the best (at least 1 cm) of the scored rows.
scored = [r['rmse_h'] for r in rows if r['count']]
best = min(scored) if scored else 0
off = [r for r in rows if r['count'] and r['rmse_h'] > 5 * max(best, 0.01)]
key = lambda r: (r['channel'], r['tag'])
# The default channels' colours (core/channel_colours.cpp).
COLOURS = {'TRUTH': '#000000', 'POSE_UWB': '#1f77b4', 'POSE_TDOA': '#ff7f0e', 'POSE_AOA': '#2ca02c',
           'POSE_FUSED': '#d62728', 'POSE_INS': '#9467bd', 'POSE_PDR': '#8c564b',
           'INS_MODULE': '#17becf', 'POSE_UWB_MODULE': '#bcbd22', 'POSE_UWB_EPOCH': '#aec7e8',
           'ALTITUDE': '#e377c2'}

# One estimator polyline per row of --json in the map and the CDF, per row within the scale in
# the error figure, each naming its row and in its channel's colour.
for fig, cls in (('map', 'estimate'), ('error_time', 'error'), ('error_cdf', 'cdf')):
    want = [key(r) for r in rows if fig != 'error_time' or r not in off]
    polys = by_class(svgs[fig], 'polyline', cls)
    got = [(p.get('data-channel'), p.get('data-tag')) for p in polys]
    check(got == want, f'{fig}.svg: "{cls}" polylines {got}, expected {want}')
    for p in polys:
        ch = p.get('data-channel')
        check(ch not in COLOURS or p.get('stroke') == COLOURS[ch], f'{fig}.svg: {ch} drawn in {p.get("stroke")}')
check(any(r['channel'] == 'POSE_FUSED' for r in rows), 'no POSE_FUSED row to check its colour')
legend_off = [t.text for t in by_class(svgs['error_time'], 'text', 'off-scale')]
want_off = [f'{r["channel"]} / {r["tag"]}  off scale: RMSE {r["rmse_h"]:.3f} m' for r in off]
check(legend_off == want_off, f'off-scale legend {legend_off}, expected {want_off}')
check(bool(by_class(svgs['error_time'], 'text', 'off-scale-note')) == bool(off), 'off-scale note')

# The map: one marker per anchor of the log's last SITE message, with its id, where it is.
site = [json.loads(line) for line in open(site_path)][-1]
anchors = {a['id']: (a['position_x_m'], a['position_y_m']) for a in site['anchors']}
m = svgs['map']
markers = by_class(m, 'circle', 'anchor')
labels = [t.text.split(' ')[0] for t in by_class(m, 'text', 'anchor-id')]
check(len(markers) == len(anchors), f'map: {len(markers)} anchor markers, SITE has {len(anchors)}')
check(sorted(labels) == sorted(anchors), f'map: anchor labels {labels}, SITE {sorted(anchors)}')
to_x, to_y = pixel_map(ticks(m, 'xtick', 'x')), pixel_map(ticks(m, 'ytick', 'y'))
for c, name in zip(markers, labels):
    x, y = to_x(float(c.get('cx'))), to_y(float(c.get('cy')))
    ax, ay = anchors[name]
    check(abs(x - ax) < 0.01 and abs(y - ay) < 0.01, f'anchor {name} drawn at ({x:.3f}, {y:.3f}), is at ({ax}, {ay})')
# Equal scale: px per metre from the x ticks equals that from the y ticks.
xt, yt = ticks(m, 'xtick', 'x'), ticks(m, 'ytick', 'y')
sx = (xt[-1][1] - xt[0][1]) / (xt[-1][0] - xt[0][0])
sy = (yt[0][1] - yt[-1][1]) / (yt[-1][0] - yt[0][0])
check(abs(sx - sy) < 0.01 * sx, f'map scale x {sx:.2f} px/m, y {sy:.2f} px/m')
truth_lines = by_class(m, 'polyline', 'truth')
static_marks = by_class(m, 'path', 'static-point')
if mode == 'static':
    check(not truth_lines and len(static_marks) == 1, f'static map: {len(truth_lines)} truth lines, {len(static_marks)} known points')
else:
    check(len(truth_lines) >= 1 and not static_marks, f'map: {len(truth_lines)} truth lines')
for poly in by_class(m, 'polyline', 'estimate') + truth_lines:
    check(len(points(poly)) <= 2000, 'map polyline with more than 2000 points')

# Heights: a line for every row with a vertical error (a height estimated), none for the 2D ones
# (rmse_v null; with truth: a static point without z scores no height at all), which the legend
# names; one per ALTITUDE row; truth's z per tag.
hs = svgs['height']
drawn = [(p.get('data-channel'), p.get('data-tag')) for p in by_class(hs, 'polyline', 'height')]
no_height = [t.text for t in by_class(hs, 'text', 'no-height')]
for r in rows:
    if r['count'] and r['rmse_v'] is not None:
        check(key(r) in drawn, f'height.svg: no height line for {key(r)}')
    elif r['count'] and mode != 'static':
        check(key(r) not in drawn, f'height.svg: height line for the 2D row {key(r)}')
        check(f'{r["channel"]} / {r["tag"]}  no height estimated' in no_height, f'height.svg legend misses 2D {key(r)}')
alt_rows = json.load(open(json_path)).get('altitude', [])
alt_lines = by_class(hs, 'polyline', 'altitude')
check(len(alt_lines) == len(alt_rows) and alt_rows, f'height.svg: {len(alt_lines)} ALTITUDE lines, {len(alt_rows)} rows')
check(all(p.get('stroke') == COLOURS['ALTITUDE'] for p in alt_lines), 'height.svg: ALTITUDE not in its colour')
if mode != 'static':
    check(len(by_class(hs, 'polyline', 'truth-height')) == len(truth_lines), 'height.svg: one truth line per tag')

# The CDFs: from y 0 to y 1, never down, one step (two points) per scored estimate.
c = svgs['error_cdf']
ys = dict(ticks(c, 'ytick', 'y'))
log_x = any(r.get('data-x-scale') == 'log' for r in by_class(c, 'rect', 'frame'))
check(log_x == bool(off), f'cdf log axis: {log_x}, rows off scale: {[key(r) for r in off]}')
for poly, row in zip(by_class(c, 'polyline', 'cdf'), rows):
    p = points(poly)
    check(len(p) == 2 * min(row['count'], 1000), f'cdf {row["channel"]}/{row["tag"]}: {len(p)} points for {row["count"]} estimates')
    if p:
        check(abs(p[0][1] - ys[0.0]) < 0.05 and abs(p[-1][1] - ys[1.0]) < 0.05, f'cdf goes from y px {p[0][1]} to {p[-1][1]}, ticks 0: {ys[0.0]}, 1: {ys[1.0]}')
        check(all(b[1] <= a[1] + 1e-9 and b[0] >= a[0] - 1e-9 for a, b in zip(p, p[1:])), 'cdf not monotone')
        # The last step is at the largest error (pixel rounding: 0.05 px).
        to_e = pixel_map(ticks(c, 'xtick', 'x'), log_x)
        check(abs(to_e(p[-1][0]) - row['max_h']) < 0.01, f'cdf ends at {to_e(p[-1][0]):.3f} m, max_h {row["max_h"]}')
check(len(by_class(c, 'circle', 'cep50')) == sum(r['count'] > 0 for r in rows), 'one CEP50 marker per scored row')
for poly, row in zip(by_class(svgs['error_time'], 'polyline', 'error'), [r for r in rows if r not in off]):
    check(len(points(poly)) == min(row['count'], 2000), f'error line: {len(points(poly))} points for {row["count"]}')

# index.html: the same SVG markup inline, nothing that loads or runs, the table's numbers.
page = open(f'{d}/index.html', encoding='utf-8').read()
for name in svgs:
    body = open(f'{d}/{name}.svg', encoding='utf-8').read()
    body = body[body.index('<svg'):].rstrip('\n')
    check(body in page, f'{name}.svg is not inline in index.html')

class Page(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags, self.bad, self.cells, self.row, self.title, self.where = [], [], [], None, '', []
        self.tables = 0  # rows of the first table (the statistics) only
    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.where.append(tag)
        for k, v in attrs:
            if k in ('src', 'href', 'xlink:href') or (v and 'url(http' in v) or k.startswith('on'):
                self.bad.append(f'<{tag} {k}={v}>')
        if tag in ('script', 'link', 'img', 'iframe', 'object', 'embed'):
            self.bad.append(tag)
        if tag == 'tr':
            self.row = []
    def handle_endtag(self, tag):
        if tag == 'table':
            self.tables += 1
        if tag == 'tr' and self.row is not None:
            if self.tables == 0:
                self.cells.append(self.row)
            self.row = None
        if self.where and self.where[-1] == tag:
            self.where.pop()
    def handle_data(self, data):
        if self.where and self.where[-1] == 'title':
            self.title += data
        if self.row is not None and self.where and self.where[-1] in ('td', 'th'):
            self.row.append(data)
p = Page()
p.feed(page)
check(p.tags.count('svg') == 4, f'index.html has {p.tags.count("svg")} <svg>')
check(not p.bad, f'index.html loads or runs something: {p.bad}')
check(log_path in p.title, f'title {p.title!r} does not name {log_path!r}')
table = [r for r in p.cells[1:] if r]
check(len(table) == len(rows), f'table has {len(table)} rows, --json {len(rows)}')
def fmt(v):
    return '-' if v is None else f'{v:.3f}'
for got, row in zip(table, rows):
    want = [row['channel'], row['tag'], str(row['count'])] + [fmt(row[k]) for k in ('mean_h', 'rmse_h', 'median_h', 'p95_h', 'max_h', 'rmse_v')]
    check(got[:len(want)] == want, f'table row {got} != {want}')
if errors:
    print('\n'.join(errors))
    sys.exit(1)
for r in off:
    check(f'<code>{r["channel"]} / {r["tag"]}</code> (RMSE {r["rmse_h"]:.3f} m)' in page, f'page does not list {key(r)} off scale')
print(f'{len(rows)} rows ({len(off)} off scale: {", ".join(r["channel"] for r in off)}), {len(anchors)} anchors, {len(truth_lines)} truth lines, {len(page)} bytes')
PY
}

site_json=$(ls "$WORK"/export/SITE.jsonl)
if out=$(check_report "$WORK/report/new" "$WORK/plain.json" "$site_json" "$LOG" truth 2>&1); then
  ok "report checks: $out"
else
  fail "report checks: $out"
fi

# Static-point mode: the known point instead of truth tracks.
"$BIN/ips-eval" --json "$LOG" --static-point 5,4 >"$WORK/static.json"
if "$BIN/ips-eval" "$LOG" --static-point 5,4 --report "$WORK/static" >/dev/null 2>"$WORK/err" &&
  out=$(check_report "$WORK/static" "$WORK/static.json" "$site_json" "$LOG" static 2>&1); then
  ok "static-point report: $out"
else
  fail "static-point report: ${out:-} $(cat "$WORK/err")"
fi

# A log without estimates (only SITE and TRUTH): exit 0, a page that says so, SVGs that parse.
python3 - "$WORK/replayed.lcm" "$WORK/no_estimates.lcm" <<'PY'
import struct, sys
data, out, i = open(sys.argv[1], 'rb').read(), bytearray(), 0
while i + 28 <= len(data):
    magic, _, _, cl, dl = struct.unpack('>IqqII', data[i:i + 28])
    if data[i + 28:i + 28 + cl] in (b'SITE', b'TRUTH'):
        out += data[i:i + 28 + cl + dl]
    i += 28 + cl + dl
open(sys.argv[2], 'wb').write(out)
PY
if "$BIN/ips-eval" "$WORK/no_estimates.lcm" --report "$WORK/empty" >/dev/null 2>"$WORK/err" &&
  grep -q "No pose estimates in this log" "$WORK/empty/index.html" &&
  python3 -c 'import sys, xml.etree.ElementTree as ET; [ET.parse(f"{sys.argv[1]}/{n}.svg") for n in ("map", "error_time", "error_cdf", "height")]' "$WORK/empty"; then
  ok "log without estimates: page says so; $(cat "$WORK/err")"
else
  fail "log without estimates: $(cat "$WORK/err")"
fi

# A DIR that cannot be written: one error line, status 2.
expect_error() {
  local pattern=$1 status=0
  shift
  "$@" >/dev/null 2>"$WORK/err" || status=$?
  if [ "$status" -eq 2 ] && [ "$(wc -l <"$WORK/err")" -eq 1 ] && grep -Eq -- "$pattern" "$WORK/err"; then
    ok "$(cat "$WORK/err") (status 2)"
  else
    fail "$*: status $status, stderr: $(cat "$WORK/err")"
  fi
}
expect_error "^ips-eval: error: cannot create report directory '/proc/foo'" \
  "$BIN/ips-eval" "$LOG" --report /proc/foo
expect_error "^ips-eval: error: --report: expected a directory" "$BIN/ips-eval" "$LOG" --report ""
touch "$WORK/a_file"
expect_error "^ips-eval: error: cannot create report directory '.*/a_file/sub'" \
  "$BIN/ips-eval" "$LOG" --report "$WORK/a_file/sub"
mkdir -p "$WORK/blocked/index.html"
expect_error "^ips-eval: error: cannot write report file '.*/blocked/index.html'" \
  "$BIN/ips-eval" "$LOG" --report "$WORK/blocked"

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
