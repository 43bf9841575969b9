#!/usr/bin/env bash
# ips-view as the lab's console (issue 24), in Debian's headless Chromium through chromedriver:
# view_console_log writes a log (two floors with SVG plans carried in the site, zones, T1 walking
# and climbing to floor 1, T2 going silent, zone events, alerts); `ips-view LOG` serves it at
# its own pace on a free loopback port, and viewer_checks.py console pauses, seeks, follows T1
# (clicking its marker), sees the floor change with the plan, the zone event and the alert,
# acknowledges it, toggles a channel and a tag, zooms; screenshots go to
# BUILD/test-output/viewer-console-*.png. Then `chromium --headless --dump-dom` and
# `--screenshot` of the finished log's page (no script of ours driving it) show the map drawn
# from the snapshot in the page. Every wait is for a condition, bounded (30 to 60 s).
# Exit 77 (skipped) when Chromium or chromedriver is not installed.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
for tool in chromium chromedriver; do
  command -v "$tool" >/dev/null || { echo "SKIP: no $tool (scripts/install-deps installs it)"; exit 77; }
done
OUT="$(cd "$BIN/.." && pwd)/test-output"
mkdir -p "$OUT"
WORK=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$WORK"
}
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }

source "$HERE/browser_lib.sh"

"$BIN/view_console_log" "$WORK/console.lcm"
view_start "$WORK/view.err" "$WORK/console.lcm" --speed 1
chromedriver_start "$WORK/chromedriver.log"
python3 "$HERE/viewer_checks.py" console "$url" --webdriver "$webdriver" \
  --screenshots "$OUT/viewer-console"

# The finished log's page, loaded by Chromium alone: the map is drawn from the page's snapshot
# (every floor: T1 on floor 1, T2 and T10 on floor 0).
view_start "$WORK/view-end.err" "$WORK/console.lcm" --speed 0
url="${url}#floor=all"
timeout 60 chromium --headless=new --no-sandbox --disable-gpu --window-size=1280,900 \
  --dump-dom "$url" >"$WORK/dom.html" 2>/dev/null || fail "chromium --dump-dom failed"
n=$(grep -Eo '<div id="map"[^>]* data-estimates="[0-9]+"' "$WORK/dom.html" | grep -Eo '[0-9]+"$' | tr -d '"')
[ "${n:-0}" -eq 5 ] || fail "the page drawn by Chromium alone has $n estimates on its map"
grep -q '<image class="plan"' "$WORK/dom.html" || fail "the page drawn by Chromium alone has no floor plan"
timeout 60 chromium --headless=new --no-sandbox --disable-gpu --window-size=1280,900 \
  --screenshot="$OUT/viewer-console-screenshot.png" "$url" >/dev/null 2>&1 ||
  fail "chromium --screenshot failed"
size=$(stat -c %s "$OUT/viewer-console-screenshot.png")
[ "$size" -gt 20000 ] || fail "the headless screenshot is only $size bytes"
echo "ok: chromium alone: $n estimates and the floor plan drawn; screenshot $size bytes"
echo "view_console: ok"
