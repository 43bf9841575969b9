#!/usr/bin/env bash
# ips-ble-aoa --capture: a capture file in the source experiments' form (PC local time with ms,
# port, the anchor's line; ../shared/reference/000_ble_aoa.md section 2) replayed
#  1. into an LCM log (--out): exactly the expected BLE_AOA messages in file order, utime (and the
#     log's event time) from the PC time read in --timezone Europe/Prague (CET in December), one
#     decoder per port (source ips-ble-aoa:<port>, duplicates and the 0..180 range judged per
#     port), --anchor-name applied; bad lines counted with their reasons; the default zone is UTC;
#  2. onto the bus (real LCM multicast in a private namespace, lcm-logger recording): --speed 2
#     takes at least half the capture's 1.2 s, --as-fast-as-possible much less, both publish
#     the same messages as --out, and the last HEALTH counts the bad lines and drops.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

CAP="$WORK/capture.csv"
{
  printf '\xef\xbb\xbf'  # saved by a Windows tool
  cat <<'EOF'
2023-12-12 9:50:26.643,COM8,+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,"6C1DEBA09862","",1606101,25
2023-12-12 9:50:26.650,COM9,+UUDF:6C1DEBA5F60C,-70,150,95,-71,39,"6C1DEBA0AAAA","",200000
2023-12-12 9:50:26.701,COM8,+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,"6C1DEBA09862","",1606101,25
2023-12-12 9:50:26.702,COM8,DEBA5F60C,-68,-3
garbage line
2023-12-12 9:50:26.743,COM8,+UUDF:6C1DEBA5F60C,-66,-29,41,0,38,"6C1DEBA09862","",1606201,26
2023-12-12 9:50:26.750,COM9,+UUDF:6C1DEBA5F60C,-69,140,90,-70,37,"6C1DEBA0AAAA","",200100
2023-12-12 9:50:27.000,COM8,OK
2023-12-12 9:50:27.843,COM8,+UUDF:6C1DEBA5F60C,-65,-27,40,0,39,"6C1DEBA09862","",1607201,27
EOF
} >"$CAP"
COMMON=(--capture "$CAP" --angle-range auto --anchor-name 6C1DEBA09862=A1)

# --- 1: --out --------------------------------------------------------------------------------
"$BIN/ips-ble-aoa" "${COMMON[@]}" --timezone Europe/Prague --out "$WORK/out.lcm" 2>"$WORK/out.err" ||
  fail "--out: status $?: $(cat "$WORK/out.err")"
grep -q "capture line 4: not a +UUDF event or an AT response: 'DEBA5F60C,-68,-3'" "$WORK/out.err" &&
  grep -q "capture line 5: capture: not 'date time,port,line': 'garbage line'" "$WORK/out.err" &&
  grep -q "capture: 9 lines, 5 events written to $WORK/out.lcm, 1 AT lines, 1 duplicates dropped, 0 dropped (angle range unknown), 2 bad lines" "$WORK/out.err" ||
  fail "--out: the bad lines or the summary: $(cat "$WORK/out.err")"
"$BIN/ips-ble-aoa" "${COMMON[@]}" --out "$WORK/utc.lcm" 2>/dev/null || fail "--out in UTC"

python3 - "$WORK" <<'PY' || fail "--out: the log"
import sys
from lcm_log import events
from lcm_messages import _Reader

work = sys.argv[1]

def ble_aoa(data):  # ble_aoa_t in declaration order (lcmtypes/ble_aoa_t.lcm)
    r = _Reader(data)
    return (r.take('q'), r.string(), r.string(), r.string(), r.take('f'), r.take('f'),
            r.take('f'), r.take('h'), r.take('q'), r.take('i'), r.string())

# 2023-12-12 09:50:26.643 CET = 08:50:26.643 UTC = 1702371026.643 s.
t0 = 1702371026643000
want = [(t0, 'ips-ble-aoa:COM8', 'A1', '6C1DEBA5F60C', -30, 42, -68, 37, 1606101, 25, ''),
        (t0 + 7000, 'ips-ble-aoa:COM9', '6C1DEBA0AAAA', '6C1DEBA5F60C', 60, 5, -70, 39, 200000, -1, ''),
        (t0 + 100000, 'ips-ble-aoa:COM8', 'A1', '6C1DEBA5F60C', -29, 41, -66, 38, 1606201, 26, ''),
        (t0 + 107000, 'ips-ble-aoa:COM9', '6C1DEBA0AAAA', '6C1DEBA5F60C', 50, 0, -69, 37, 200100, -1, ''),
        (t0 + 1200000, 'ips-ble-aoa:COM8', 'A1', '6C1DEBA5F60C', -27, 40, -65, 39, 1607201, 27, '')]
log, read, size = events(f'{work}/out.lcm')
assert read == size, (read, size)
assert [ch for ch, _, _ in log] == ['BLE_AOA'] * 5, log
got = [ble_aoa(d) for _, _, d in log]
assert got == want, f'\n got  {got}\n want {want}'
assert [ts for _, ts, _ in log] == [w[0] for w in want], 'log event times are not the utimes'
utc = [ble_aoa(d)[0] for _, _, d in events(f'{work}/utc.lcm')[0]]
assert utc == [w[0] + 3600 * 10**6 for w in want], utc
print('ok: --out: 5 messages exactly, times in Europe/Prague; the default zone is UTC')
PY

# --- 2: onto the bus -------------------------------------------------------------------------
lcm-logger -q -f "$WORK/live.lcm" & logger=$!; pids+=($logger)
"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
logger_sync "$WORK/live.lcm"
t0=$(date +%s%N)
"$BIN/ips-ble-aoa" "${COMMON[@]}" --timezone +01:00 --speed 2 2>"$WORK/live.err" ||
  fail "--speed 2: status $?: $(cat "$WORK/live.err")"
t1=$(date +%s%N)
"$BIN/ips-ble-aoa" "${COMMON[@]}" --timezone +01:00 --as-fast-as-possible 2>"$WORK/fast.err" ||
  fail "--as-fast-as-possible: status $?: $(cat "$WORK/fast.err")"
t2=$(date +%s%N)
logger_sync "$WORK/live.lcm"
stop $logger lcm-logger
python3 - "$WORK" $((t1 - t0)) $((t2 - t1)) <<'PY' || fail "onto the bus"
import sys
from lcm_log import events
from lcm_messages import health

work, paced_ns, fast_ns = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
out = [d for ch, _, d in events(f'{work}/out.lcm')[0]]
live = events(f'{work}/live.lcm')[0]
aoa = [d for ch, _, d in live if ch == 'BLE_AOA']
assert aoa == out + out, f'{len(aoa)} BLE_AOA messages on the bus, not the --out ones twice'
assert paced_ns >= 600e6, f'--speed 2 took {paced_ns / 1e9:.3f} s for 1.2 s of capture'
assert fast_ns < paced_ns, (fast_ns, paced_ns)
hb = [health(d) for ch, _, d in live if ch == 'HEALTH']
hb = [h for h in hb if h['source'] == 'ips-ble-aoa']
assert len(hb) >= 2, hb
last = hb[-1]
assert (last['msgs_in'], last['msgs_out'], last['parse_errors'], last['drops']) == (9, 5, 2, 1), last
print(f'ok: on the bus: the same 5 messages paced ({paced_ns / 1e9:.2f} s at x2) and as fast as '
      f'possible ({fast_ns / 1e9:.2f} s); HEALTH msgs_in 9, parse_errors 2, drops 1')
PY
