#!/usr/bin/env bash
# ips-view's HTTP server under abuse (issue 26), in a private network namespace, with the default
# limits (32 connections, 8 per address, 2 s header timeout, 4 KiB bodies, 1 MiB of events
# behind per page): tests/integration/http_abuse.py holds a flood of 1000 connections that send
# nothing (from 127.0.0.10-17, each opened again when closed, 200 a second), sends every
# malformed and oversized case (1 MiB header line, huge and 2 MiB bodies, garbage, NUL bytes,
# HTTP/0.9, HTTP/2.0, bad Content-Length, chunked junk, pipelined junk, resets mid-head and
# mid-body; 5 rounds, then 20 a second) from 127.0.0.30-37, and keeps 48 slow readers that
# never read, more than there are slots (127.0.0.40-45, 8 each: 400 pipelined GETs of /view.js,
# or the event stream /events; 4 KiB receive buffers). A slow reader is evicted once it has
# taken nothing for 2 s, an event stream of an address holding 2 more connections than the
# newcomer's when nothing else can be: so meanwhile 20 page loads from 127.0.0.1 each get the
# page within 1 s. The process stays up, its peak RSS (VmHWM) stays under 64 MiB (measured
# 10 MiB; the bound is 32 pages' 1 MiB backlogs and more; 256 MiB for a sanitizer build), and
# the refusals are counted: /api/info's http_refusals and the last log line ("HTTP connections:
# ...; refusals: 400 xN, ...") hold at least what the clients were answered, status by status,
# and no more 431/413/505/501/417/411 than the cases that cause them were sent; HEALTH counts
# the connections cut (408) and refused (503) as drops.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
source "$ROOT/tests/integration/http_abuse_lib.sh"
ulimit -n 4096 2>/dev/null || true
STARVE="$ROOT/tests/integration/http_starve.py"
PORT=47105
MAX_RSS_KIB=$((64 * 1024))
if grep -qa __asan_init "$BIN/ips-view"; then MAX_RSS_KIB=$((256 * 1024)); fi

lcm-logger -q -f "$WORK/bus.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
logger_sync "$WORK/bus.lcm"
"$BIN/ips-view" --port $PORT 2>"$WORK/view.err" & view=$!; pids+=($view)
for ((i = 0; i < 1200; i++)); do grep -q "serving http" "$WORK/view.err" 2>/dev/null && break; sleep 0.05; done
grep -q "serving http" "$WORK/view.err" || fail "ips-view did not start: $(cat "$WORK/view.err")"

probe() {
  python3 "$STARVE" probe $PORT --method GET --path / --expect '<!doctype html>' "$@"
}
quiet=$(probe --count 3 --every 0.05 --require) || fail "page loads without abuse: $quiet"

abuse_start $view ips-view $PORT --get /view.js --post / --stream /events --body-limit 4096 \
  --body-limit-status 405 --rounds 5 --slow-readers 48 \
  --slow-from 127.0.0.40,127.0.0.41,127.0.0.42,127.0.0.43,127.0.0.44,127.0.0.45 --settle-s 3
attacked=$(probe --count 20 --every 0.2 --deadline 1.0 --require --out "$WORK/probe.json") ||
  fail "page loads under abuse: $attacked; $(tail -3 "$WORK/view.err")"
abuse_stop $view ips-view
after=$(probe --count 5 --every 0.05 --deadline 1.0 --require) || fail "page loads after: $after"
python3 - $PORT >"$WORK/info.json" <<'PY' || fail "GET /api/info after the abuse"
import sys, urllib.request
print(urllib.request.urlopen(f'http://127.0.0.1:{sys.argv[1]}/api/info', timeout=10).read().decode())
PY
hwm=$(peak_rss_kib $view)

python3 "$HERE/../drivers/health_wait.py" "$WORK/bus.lcm" --source ips-view --after "$ended" ||
  fail "no HEALTH after the abuse"
stop $view ips-view
logger_sync "$WORK/bus.lcm"
stop $logger lcm-logger
[ "$hwm" -lt "$MAX_RSS_KIB" ] || fail "peak RSS ${hwm} KiB, over ${MAX_RSS_KIB} KiB"
abuse_check "$WORK/view.err"
python3 - "$WORK" "$hwm" "$ended" <<'PY' || fail "the counts in /api/info and HEALTH"
import json, sys
from lcm_log import events
from lcm_messages import health
work, hwm, ended = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
c = json.load(open(f'{work}/check.json'))
ref, saw, s = c['server']['refusals'], c['clients_saw'], c['server']
info = json.load(open(f'{work}/info.json'))
# /api/info, asked after the abuse: what the clients saw <= its counts <= the final ones.
for code, n in saw.items():
    if not code.startswith('2'):
        assert n <= info['http_refusals'].get(code, 0) <= ref[code], (code, info, ref, saw)
assert info['http_refused'] == sum(info['http_refusals'].values()), info
assert 0 < info['http_connections']['aborted'] <= s['aborted'], (info, s)
# The slow readers held more than every slot: some were evicted, pipelining and streaming.
assert s['evicted_readers'] > 0 and s['evicted_streams'] > 0, s
assert info['http_connections']['evicted_streams'] <= s['evicted_streams'], (info, s)
hb = [health(d) for ch, _, d in events(f'{work}/bus.lcm')[0] if ch == 'HEALTH']
last = [h for h in hb if h['source'] == 'ips-view'][-1]
assert last['utime'] > ended, last
assert ref.get('408', 0) + ref.get('503', 0) >= last['drops'] >= \
    saw.get('408', 0) + saw.get('503', 0) > 100, (last, ref, saw)
p = json.load(open(f'{work}/probe.json'))
print(f"ok: {p['ok']}/{p['count']} page loads within 1 s under abuse (median "
      f"{p['latency_median_s'] * 1000:.1f} ms, max {p['latency_max_s'] * 1000:.1f} ms); peak RSS "
      f"{hwm / 1024:.1f} MiB; {c['flood_opened']} flood connections, {c['cases_sent']} bad "
      f"requests, {c['slow_readers']} slow readers; the server: {s['accepted']} accepted, "
      f"{s['refused']} refused (503), {s['evicted']} evicted ({s['evicted_readers']} not reading, "
      f"{s['evicted_streams']} streams), {s['aborted']} aborted, refusals "
      f"{ref}; HEALTH drops {last['drops']}")
PY
