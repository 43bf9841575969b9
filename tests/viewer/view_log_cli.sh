#!/usr/bin/env bash
# ips-view on a log (no bus needed): 20 s of the simulated lab run through ips-replay, then
#  1. served (--speed 0, --port 0): every HTTP route checked by viewer_checks.py endpoints, and
#     every TRUTH message of the log shown; SIGINT ends it with status 0;
#  2. served at --speed 2: the page's clock advances 2x the wall clock, T1's truth with it;
#  3. rendered to SVG (end of the log, and --at 5 s) and PNG (rsvg-convert; --zoom 2 doubles it);
#  4. the errors: a bad --out, a missing log, LOG with --live or --wait-site, an existing --out,
#     a port in use,
#     PNG without rsvg-convert.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/cli_test_lib.sh"
export PYTHONPATH="$ROOT/tests/integration"
WORK=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  rm -rf "$WORK"
}
trap cleanup EXIT

"$BIN/ips-sim" --scenario lab --seed 2 --duration 20 --out "$WORK/sim.lcm" --log-level warn
"$BIN/ips-replay" "$WORK/sim.lcm" --out "$WORK/lab.lcm" --log-level warn

# Starts ips-view with ARGS on a free port; sets VIEW (its pid) and URL.
start_view() {
  : >"$WORK/view.err"
  "$BIN/ips-view" --port 0 "$@" 2>"$WORK/view.err" & VIEW=$!; pids+=($VIEW)
  URL=
  local deadline=$((SECONDS + 60))
  while [ "$SECONDS" -lt "$deadline" ]; do
    URL=$(sed -nE 's|^ips-view: serving (http://[^ ]+/) .*|\1|p' "$WORK/view.err")
    [ -n "$URL" ] && break
    kill -0 "$VIEW" 2>/dev/null || fail "ips-view $* exited: $(cat "$WORK/view.err")"
    sleep 0.1
  done
  [ -n "$URL" ] || fail "ips-view $* did not print its address: $(cat "$WORK/view.err")"
}
stop_view() {
  kill -INT "$VIEW"
  local rc=0
  wait "$VIEW" || rc=$?
  [ "$rc" -eq 0 ] || fail "ips-view exited with status $rc after SIGINT: $(cat "$WORK/view.err")"
}

# --- 1: the whole log at once, every route ------------------------------------------------
start_view "$WORK/lab.lcm" --speed 0
deadline=$((SECONDS + 60))
until grep -q 'end of the log' "$WORK/view.err" || [ "$SECONDS" -ge "$deadline" ]; do sleep 0.1; done
grep -q 'end of the log' "$WORK/view.err" || fail "no end-of-log line: $(cat "$WORK/view.err")"
python3 "$HERE/viewer_checks.py" endpoints "$URL" --mode log --log "$WORK/lab.lcm" \
  --channels TRUTH,POSE_UWB,POSE_TDOA,POSE_AOA,POSE_FUSED
stop_view

# --- 2: paced playback follows the log's clock -----------------------------------------------
start_view "$WORK/lab.lcm" --speed 2
python3 - "$URL" <<'EOF'
import json, sys, time, urllib.request
url = sys.argv[1]
def get(path):
    return json.load(urllib.request.urlopen(url + path, timeout=30))
def truth(s):
    return next((t for t in s['tracks'] if t['channel'] == 'TRUTH' and t['tag'] == 'T1'), None)
deadline = time.time() + 60
while True:
    w0 = time.time()
    s = get('api/state?trails=0')
    w1 = time.time()
    if truth(s):
        break
    assert w1 < deadline, 'no TRUTH T1 within 60 s'
    time.sleep(0.05)
a, ta = truth(s), s['now_utime']
time.sleep(1.0)
w2 = time.time()
b = get('api/state?trails=0')
w3 = time.time()
done = get('api/info')['log_done']
dt = (b['now_utime'] - ta) / 1e6
# At 2x the log clock advances 2 s per second of wall time between the two snapshots: at least
# the time between the first's answer and the second's request, at most the time from the
# first's request to the second's answer (measured: a loaded machine stretches both), within
# 20 % and half a second of log for the playback's steps. Nominally 2 s of the 20 s log, which
# plays for 10 s: a loaded machine can be slow to start and still sample it before its end.
lo, hi = 2 * (w2 - w1), 2 * (w3 - w0)
assert dt <= 1.2 * hi + 0.5, f'log clock advanced {dt:.2f} s in {w3 - w0:.2f} s of wall at --speed 2'
assert done or dt >= 0.8 * lo - 0.5, \
    f'log clock advanced {dt:.2f} s in {w2 - w1:.2f} s of wall at --speed 2'
assert truth(b)['count'] > a['count'], 'TRUTH T1 did not advance'
print(f'--speed 2: the log clock advanced {dt:.1f} s in {w2 - w1:.2f} to {w3 - w0:.2f} s of '
      f'wall time; TRUTH T1 {a["count"]} -> {truth(b)["count"]} positions')
EOF
stop_view

# --- 3: render -------------------------------------------------------------------------
"$BIN/ips-view" render "$WORK/lab.lcm" --out "$WORK/end.svg" 2>"$WORK/render.err" ||
  fail "render failed: $(cat "$WORK/render.err")"
grep -q 'wrote .*end.svg: site lab, .* estimates of 1 tag on 7 channels, at 20.0 s of the log' \
  "$WORK/render.err" || fail "render summary: $(cat "$WORK/render.err")"
"$BIN/ips-view" render "$WORK/lab.lcm" --at 5 --out "$WORK/at5.svg" 2>"$WORK/render.err"
grep -q 'at 5.0 s of the log' "$WORK/render.err" || fail "--at 5: $(cat "$WORK/render.err")"
"$BIN/ips-view" render "$WORK/lab.lcm" --at 60 --out "$WORK/at60.svg" 2>"$WORK/render.err"
grep -q 'warning: --at 60 s is past the end of the log (20.0 s)' "$WORK/render.err" ||
  fail "--at past the end: $(cat "$WORK/render.err")"
cmp -s "$WORK/end.svg" "$WORK/at60.svg" || fail "--at past the end differs from the end"
python3 - "$WORK/end.svg" "$WORK/at5.svg" <<'EOF'
import sys, xml.etree.ElementTree as ET
S = '{http://www.w3.org/2000/svg}'
def truth_at(path):
    root = ET.parse(path).getroot()
    assert root.tag == S + 'svg', root.tag
    assert 'lab' in root.find(S + 'title').text
    c = [c for c in root.iter(S + 'circle') if c.get('class') == 'estimate']
    assert len(c) >= 5, f"{path}: {len(c)} estimates (T1 on 7 channels by the end)"
    t = [x for x in c if x.find(S + 'title').text.startswith('TRUTH T1 (')]
    return float(t[0].get('cx')), float(t[0].get('cy'))
end, at5 = truth_at(sys.argv[1]), truth_at(sys.argv[2])
assert abs(end[0] - at5[0]) + abs(end[1] - at5[1]) > 20, f'T1 at 5 s {at5} and 20 s {end}'
print(f'render: T1 drawn at {at5} px at 5 s, {end} px at 20 s')
EOF
"$BIN/ips-view" render "$WORK/lab.lcm" --out "$WORK/map.png" 2>"$WORK/render.err" ||
  fail "PNG render: $(cat "$WORK/render.err")"
"$BIN/ips-view" render "$WORK/lab.lcm" --out "$WORK/map2.png" --zoom 2 2>/dev/null
python3 - "$WORK/end.svg" "$WORK/map.png" "$WORK/map2.png" <<'EOF'
import struct, sys, xml.etree.ElementTree as ET
svg = ET.parse(sys.argv[1]).getroot()
w, h = float(svg.get('width')), float(svg.get('height'))
def size(path):
    b = open(path, 'rb').read()
    assert b[:8] == b'\x89PNG\r\n\x1a\n', f'{path} is not a PNG'
    return struct.unpack('>II', b[16:24]), len(b)
(w1, h1), n1 = size(sys.argv[2])
(w2, h2), n2 = size(sys.argv[3])
assert abs(w1 - w) <= 1 and abs(h1 - h) <= 1, f'PNG {w1}x{h1}, SVG {w}x{h}'
assert abs(w2 - 2 * w1) <= 2 and abs(h2 - 2 * h1) <= 2, f'--zoom 2: {w2}x{h2} vs {w1}x{h1}'
assert n1 > 5000, f'PNG of {n1} bytes'
print(f'PNG {w1}x{h1} ({n1} bytes), --zoom 2 {w2}x{h2}')
EOF

# --- 4: errors ---------------------------------------------------------------------------
expect_error_saying "must end in .svg or .png" "$BIN/ips-view" render "$WORK/lab.lcm" --out "$WORK/x.txt"
expect_error_saying "cannot read log '$WORK/none.lcm'" "$BIN/ips-view" render "$WORK/none.lcm" --out "$WORK/x.svg"
expect_error_saying "give either a LOG or --live" "$BIN/ips-view" render "$WORK/lab.lcm" --live 1 --out "$WORK/x.svg"
expect_error_saying "give either a LOG or --live" "$BIN/ips-view" render --out "$WORK/x.svg"
expect_error_saying "--wait-site goes with --live" "$BIN/ips-view" render "$WORK/lab.lcm" --wait-site 5 --out "$WORK/x.svg"
expect_error_saying "--min-tracks goes with --wait-site" "$BIN/ips-view" render --live 1 --min-tracks 2 --out "$WORK/x.svg"
expect_error_saying "exists (--force to overwrite)" "$BIN/ips-view" render "$WORK/lab.lcm" --out "$WORK/end.svg"
"$BIN/ips-view" render "$WORK/lab.lcm" --out "$WORK/end.svg" --force 2>/dev/null || fail "--force"
expect_error_saying "cannot read log" "$BIN/ips-view" "$WORK/none.lcm"
expect_error_saying "--speed" "$BIN/ips-view" "$WORK/lab.lcm" --speed -1
# No rsvg-convert on the PATH: one line naming the package.
mkdir -p "$WORK/nobin"
set +e
err=$(PATH="$WORK/nobin" "$BIN/ips-view" render "$WORK/lab.lcm" --out "$WORK/n.png" 2>&1 >/dev/null)
rc=$?
set -e
[ "$rc" -eq 1 ] && echo "$err" | grep -q 'needs rsvg-convert.*librsvg2-bin' ||
  fail "PNG without rsvg-convert: status $rc: $err"
[ ! -e "$WORK/n.png" ] || fail "a PNG was written without rsvg-convert"
echo "ok: $err"
# A port in use: one line, status 1.
python3 -c 'import socket,time,sys; s=socket.socket(); s.bind(("127.0.0.1",0)); s.listen(); print(s.getsockname()[1], flush=True); time.sleep(600)' >"$WORK/port" & holder=$!; pids+=($holder)
deadline=$((SECONDS + 60))
until [ -s "$WORK/port" ] || [ "$SECONDS" -ge "$deadline" ]; do sleep 0.1; done
set +e
err=$("$BIN/ips-view" "$WORK/lab.lcm" --port "$(cat "$WORK/port")" 2>&1 >/dev/null)
rc=$?
set -e
[ "$rc" -eq 1 ] && echo "$err" | grep -q "^ips-view: error: cannot listen on TCP 127.0.0.1:$(cat "$WORK/port"): Address already in use" ||
  fail "port in use: status $rc: $err"
echo "ok: $err"
kill "$holder"
wait "$holder" 2>/dev/null || true
echo "view_log_cli: ok"
