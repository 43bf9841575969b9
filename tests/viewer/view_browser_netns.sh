#!/usr/bin/env bash
# ips-view live, end to end, in a private network namespace over real LCM multicast:
# ips-sim (the lab, plus a second walker whose tag id is HTML markup) and ips-uwb-twr run as
# separate processes; plain `ips-view` serves the bus on its default 127.0.0.1:8080.
#  1. every HTTP route (viewer_checks.py endpoints --mode live);
#  2. Debian's headless Chromium, driven through chromedriver, loads the page, waits for T1 to
#     move on the map and in the table, checks the tables and that the tag named with markup is
#     only text, and saves a screenshot to BUILD/test-output/viewer-live.png;
#  3. `ips-view render --live 2` draws the bus to SVG.
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
text = text.replace('    - {id: T1, height_m: 1.2}\n',
                    '    - {id: T1, height_m: 1.2}\n    - {id: %s, height_m: 1.0}\n' % tag, 1)
text = text.replace('trajectories:\n', 'trajectories:\n  - tag: %s\n    loop: true\n'
                    '    speed_mps: 0.8\n    height_m: 1.0\n'
                    '    waypoints: [[3.0, 3.0], [7.0, 3.0], [7.0, 5.0], [3.0, 5.0]]\n' % tag, 1)
assert text.count(tag) == 2, 'lab.yaml changed shape: the test cannot add its tag'
open(sys.argv[2], 'w').write(text)
EOF

"$BIN/ips-bus-check" --timeout 3 || fail "multicast does not loop back inside the namespace"
"$BIN/ips-uwb-twr" --log-level warn & twr=$!; pids+=($twr)
"$BIN/ips-view" --log-level warn 2>"$WORK/view.err" & view=$!; pids+=($view)
"$BIN/ips-bus-check" --wait-for ips-uwb-twr --wait-for ips-view --timeout 20 ||
  fail "ips-uwb-twr or ips-view did not come up: $(cat "$WORK/view.err")"
grep -q '^ips-view: serving http://127.0.0.1:8080/ (live bus)' "$WORK/view.err" ||
  fail "ips-view's first line: $(cat "$WORK/view.err")"
"$BIN/ips-sim" --scenario "$WORK/lab-markup.yaml" --duration 300 --log-level warn & sim=$!
pids+=($sim)
chromedriver --port=9515 >"$WORK/chromedriver.log" 2>&1 & driver=$!; pids+=($driver)
for _ in $(seq 100); do
  python3 -c 'import urllib.request; urllib.request.urlopen("http://127.0.0.1:9515/status", timeout=1)' 2>/dev/null && break
  sleep 0.1
done
# Let the first estimates arrive.
sleep 2

python3 "$HERE/viewer_checks.py" endpoints http://127.0.0.1:8080/ --mode live
python3 "$HERE/viewer_checks.py" browser http://127.0.0.1:8080/ --webdriver http://127.0.0.1:9515 \
  --screenshot "$OUT/viewer-live.png" --payload "$PAYLOAD"

"$BIN/ips-view" render --live 2 --out "$WORK/live.svg" 2>"$WORK/render.err" ||
  fail "render --live: $(cat "$WORK/render.err")"
grep -q 'wrote .*live.svg: site lab, .* estimates of 2 tags on 3 channels, after 2 s of the live bus' \
  "$WORK/render.err" || fail "render --live summary: $(cat "$WORK/render.err")"
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
