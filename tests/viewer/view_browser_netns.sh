#!/usr/bin/env bash
# ips-view live, end to end, in a private network namespace over real LCM multicast:
# ips-sim (the lab, plus a second walker whose tag id is HTML markup) and ips-uwb-twr run as
# separate processes; plain `ips-view` serves the bus on its default 127.0.0.1:8080.
#  1. every HTTP route (viewer_checks.py endpoints --mode live);
#  2. Debian's headless Chromium, driven through chromedriver, loads the page, waits for T1 to
#     move on the map and in the table, checks the tables and that the tag named with markup is
#     only text, and saves a screenshot to BUILD/test-output/viewer-live.png;
#  3. `ips-view render --live 2 --wait-site 60 --min-tracks 6` draws the bus to SVG (ips-sim
#     repeats SITE every 5 s, and a loaded machine can be late with an estimate: render listens on
#     until a SITE and both tags on all 3 channels have come).
# Every wait is for a condition (a process on HEALTH, the page's state, a SITE), bounded by 60 s.
# Exit 77 (skipped) when no network namespace can be made here, or Chromium is not installed.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
for tool in chromium chromedriver; do
  command -v "$tool" >/dev/null || { echo "SKIP: no $tool (scripts/install-deps installs it)"; exit 77; }
done
source "$ROOT/tests/integration/live_test_lib.sh"
OUT="$(cd "$BIN/.." && pwd)/test-output"
mkdir -p "$OUT"

PAYLOAD='<img src=x onerror=window.pwned=1><script>window.pwned=2</script><b>x</b>'
# The lab scenario with a second tag, named PAYLOAD, walking its own loop.
python3 - "$ROOT/config/scenarios/lab.yaml" "$WORK/lab-markup.yaml" "$PAYLOAD" <<'EOF'
import json, sys
text = open(sys.argv[1]).read()
tag = json.dumps(sys.argv[3])  # a JSON string is a YAML string
text = text.replace('start_heading_deg: 0}\n',
                    'start_heading_deg: 0}\n    - {id: %s, height_m: 1.0}\n' % tag, 1)
text = text.replace('trajectories:\n', 'trajectories:\n  - tag: %s\n    loop: true\n'
                    '    speed_mps: 0.8\n    height_m: 1.0\n'
                    '    waypoints: [[3.0, 3.0], [7.0, 3.0], [7.0, 5.0], [3.0, 5.0]]\n' % tag, 1)
assert text.count(tag) == 2, 'lab.yaml changed shape: the test cannot add its tag'
open(sys.argv[2], 'w').write(text)
EOF

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
"$BIN/ips-uwb-twr" --log-level warn & twr=$!; pids+=($twr)
"$BIN/ips-view" --log-level warn 2>"$WORK/view.err" & view=$!; pids+=($view)
"$BIN/ips-bus-check" --wait-for ips-uwb-twr --wait-for ips-view --timeout 60 ||
  fail "ips-uwb-twr or ips-view did not come up: $(cat "$WORK/view.err")"
grep -q '^ips-view: serving http://127.0.0.1:8080/ (live bus)' "$WORK/view.err" ||
  fail "ips-view's first line: $(cat "$WORK/view.err")"
# No SITE on the bus yet: render --wait-site gives up after its bound, writes nothing, status 1
# (nothing can come: ips-sim has not started).
rc=0
"$BIN/ips-view" render --live 0.2 --wait-site 0.3 --out "$WORK/nosite.svg" 2>"$WORK/render.err" ||
  rc=$?
[ "$rc" -eq 1 ] && [ ! -e "$WORK/nosite.svg" ] &&
  grep -Eq '^ips-view: error: no SITE message on SITE within [0-9.]+ s \(--live 0\.2, --wait-site 0\.3\): nothing written$' \
    "$WORK/render.err" ||
  fail "render --wait-site without a SITE: status $rc: $(cat "$WORK/render.err")"
echo "ok: $(cat "$WORK/render.err")"
"$BIN/ips-sim" --scenario "$WORK/lab-markup.yaml" --duration 300 --log-level warn & sim=$!
pids+=($sim)
chromedriver --port=9515 >"$WORK/chromedriver.log" 2>&1 & driver=$!; pids+=($driver)
deadline=$((SECONDS + 60))
until python3 -c 'import urllib.request; urllib.request.urlopen("http://127.0.0.1:9515/status", timeout=5)' 2>/dev/null; do
  [ "$SECONDS" -lt "$deadline" ] || fail "chromedriver did not answer within 60 s: $(cat "$WORK/chromedriver.log")"
  sleep 0.1
done

# endpoints --mode live first waits (at most 60 s) for the site and T1 on every channel.
python3 "$HERE/viewer_checks.py" endpoints http://127.0.0.1:8080/ --mode live
python3 "$HERE/viewer_checks.py" browser http://127.0.0.1:8080/ --webdriver http://127.0.0.1:9515 \
  --screenshot "$OUT/viewer-live.png" --payload "$PAYLOAD"

# T1 and the markup tag on TRUTH, POSE_UWB and INS_MODULE: 6 tracks.
"$BIN/ips-view" render --live 2 --wait-site 60 --min-tracks 6 --out "$WORK/live.svg" \
  2>"$WORK/render.err" || fail "render --live: $(cat "$WORK/render.err")"
grep -Eq 'wrote .*live.svg: site lab, 6 estimates of 2 tags on 3 channels, after [0-9.]+ s of the live bus' \
  "$WORK/render.err" || fail "render --live summary: $(cat "$WORK/render.err")"
grep 'wrote .*live.svg' "$WORK/render.err"
# More tracks than the bus carries: render gives up after its bound, writes nothing, status 1 (the
# site is the file's, so only the tracks are waited for).
rc=0
"$BIN/ips-view" render --site "$ROOT/config/sites/lab.yaml" --live 0.2 --wait-site 0.5 --min-tracks 7 \
  --out "$WORK/seven.svg" 2>"$WORK/render.err" || rc=$?
[ "$rc" -eq 1 ] && [ ! -e "$WORK/seven.svg" ] &&
  grep -Eq '^ips-view: error: [0-6] of --min-tracks 7 tracks on the map within [0-9.]+ s \(--live 0\.2, --wait-site 0\.5\): nothing written$' \
    "$WORK/render.err" ||
  fail "render --min-tracks 7: status $rc: $(cat "$WORK/render.err")"
echo "ok: $(cat "$WORK/render.err")"
python3 - "$WORK/live.svg" "$PAYLOAD" <<'EOF'
import sys, xml.etree.ElementTree as ET
S = '{http://www.w3.org/2000/svg}'
root = ET.parse(sys.argv[1]).getroot()
labels = [t.text for t in root.iter(S + 'text') if t.get('class') == 'tag-id']
# Long labels are cut to "<start>...".
markup = [l for l in labels if l == sys.argv[2] or
          (l.endswith('...') and len(l) > 10 and sys.argv[2].startswith(l[:-3]))]
# T1 on TRUTH, POSE_UWB and INS_MODULE (the simulated foot module).
assert labels.count('T1') == 3 and len(markup) >= 1, labels
assert not list(root.iter(S + 'script')) and not list(root.iter('img')), 'markup in the SVG'
print(f'render --live: tag labels {labels}')
EOF

stop $sim ips-sim
stop $view ips-view
stop $twr ips-uwb-twr
kill $driver 2>/dev/null || true
echo "view_browser_netns: ok"
