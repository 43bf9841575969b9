#!/usr/bin/env bash
# ips-view cannot be starved (issue 28), in a private network namespace: with 200 connections
# held open that send nothing (from 127.0.0.2 and 127.0.0.3, each opened again as soon as the
# server closes it) and a slowloris of 10 connections (127.0.0.4: a request head a byte every
# 0.5 s, opened again when cut), 20 page loads (GET /, each a new connection from 127.0.0.1,
# every 0.2 s) all get the page within 1 s, and HEALTH tells the connections cut. Default limits
# (32 connections, 8 per address, 2 s header timeout). Prints the latencies.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
ulimit -n 4096 2>/dev/null || true
STARVE="$ROOT/tests/integration/http_starve.py"
PORT=47103

lcm-logger -q -f "$WORK/bus.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
logger_sync "$WORK/bus.lcm"
"$BIN/ips-view" --port $PORT 2>"$WORK/view.err" & view=$!; pids+=($view)
for ((i = 0; i < 1200; i++)); do grep -q "serving http" "$WORK/view.err" 2>/dev/null && break; sleep 0.05; done
grep -q "serving http" "$WORK/view.err" || fail "ips-view did not start: $(cat "$WORK/view.err")"

probe() {
  python3 "$STARVE" probe $PORT --method GET --path / --expect '<!doctype html>' "$@"
}
quiet=$(probe --count 3 --every 0.05 --require) || fail "page loads without an attack: $quiet"

python3 "$STARVE" attack $PORT --ready "$WORK/ready" --stats "$WORK/attack.json" \
  --idle 200 --idle-from 127.0.0.2,127.0.0.3 --slow 10 --slow-from 127.0.0.4 & atk=$!
pids+=($atk)
for ((i = 0; i < 1200; i++)); do [ -s "$WORK/ready" ] && break; sleep 0.05; done
[ -s "$WORK/ready" ] || fail "the attack did not open its connections within 60 s"
# Page loads 4 s long: the slowloris is cut (2 s) and comes back meanwhile.
attacked=$(probe --count 20 --every 0.2 --deadline 1.0 --require --out "$WORK/probe.json") ||
  fail "page loads under attack: $attacked; $(tail -3 "$WORK/view.err")"
kill -TERM $atk
wait $atk || fail "the attack process failed"
forget $atk

python3 "$HERE/../drivers/health_wait.py" "$WORK/bus.lcm" --source ips-view \
  --error "connections so far:" || fail "no HEALTH telling the connections cut"
stop $view ips-view
logger_sync "$WORK/bus.lcm"
stop $logger lcm-logger
python3 - "$WORK" <<'PY' || fail "HEALTH counts"
import json, sys
from lcm_log import events
from lcm_messages import health
work = sys.argv[1]
atk = json.load(open(f'{work}/attack.json'))
hb = [health(d) for ch, _, d in events(f'{work}/bus.lcm')[0] if ch == 'HEALTH']
last = [h for h in hb if h['source'] == 'ips-view'][-1]
# Every connection the server closed is a drop (408 evicted or timed out, 503 refused).
assert last['drops'] >= atk['closed_by_server'] > 200, (last, atk)
p = json.load(open(f'{work}/probe.json'))
print(f"ok: {p['ok']}/{p['count']} page loads within 1 s under attack (median "
      f"{p['latency_median_s'] * 1000:.1f} ms, max {p['latency_max_s'] * 1000:.1f} ms); the "
      f"attack opened {atk['opened']} connections, {atk['closed_by_server']} closed by the "
      f"server; HEALTH drops {last['drops']}")
PY
