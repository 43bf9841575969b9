#!/usr/bin/env bash
# ips-uwb-tdoa-anchors end to end over real TCP and UDP on loopback and real LCM multicast in a
# private network namespace, recorded by the real lcm-logger:
#  1. ips-sim (tdoa-hall, 5 s) -> ips-uwb-tdoa-anchors --to-records -> one record per UWB_RX
#     message, with the --id options that name the wire ids back as the simulator's;
#  2. --tcp: the driver starts before the server is there; a Python server sends half the
#     records in small pieces, goes away for 1.5 s, comes back and sends the rest: every record
#     is published once, in order, and HEALTH says degraded ("reconnecting") while it was gone
#     and OK again after;
#  3. --udp: the records as datagrams of one to three records (newline-separated or back to
#     back), then bad datagrams: every record is published, the bad ones are parse errors;
#  4. --file with garbled records mixed in (paced with --rate): every good record is published,
#     each bad one counted in HEALTH parse_errors; `cat | --file -`; and source 004's three
#     examples with --rx-power dw1000-prf64 (the DW1000 receive levels of their diagnostics);
# in each, the published UWB_RX equal the simulator's (anchor and sender ids, is_sync, seq,
# rx_counter exactly, counter_hz, NaN powers; the driver's HEALTH counts them all, lcm-logger may
# miss a few under load) and are stamped with host time.
# Exit 77 (skipped) when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
DRV="$BIN/ips-uwb-tdoa-anchors"
now_us() { date +%s%6N; }
# Waits until something listens on UDP port $1 in this namespace (/proc/net/udp, hex port).
wait_udp_bound() {
  local hex; hex=$(printf '%04X' "$1")
  for _ in $(seq 1200); do
    grep -q "^ *[0-9]*: [0-9A-F]*:$hex " /proc/net/udp && return 0
    sleep 0.05
  done
  fail "nothing bound UDP port $1"
}

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"

# --- 1: a simulated log as records ----------------------------------------------------------
"$BIN/ips-sim" --scenario tdoa-hall --duration 5 --out "$WORK/sim.lcm" --log-level warn
"$DRV" --to-records "$WORK/sim.lcm" > "$WORK/recs.txt" 2> "$WORK/to_records.err" ||
  fail "--to-records: $(cat "$WORK/to_records.err")"
read -r -a IDS <<< "$(grep -o -- '--id [0-9a-f]\{4\}=[A-Za-z0-9]*' "$WORK/to_records.err" | tr '\n' ' ')"
[ "${#IDS[@]}" -eq 14 ] || fail "expected 7 --id options for A1..A6, T1: $(cat "$WORK/to_records.err")"
n=$(wc -l < "$WORK/recs.txt")
[ "$n" -ge 250 ] || fail "--to-records wrote $n records (expected one per UWB_RX, about 300)"
grep -qE '^\|0004\|E\|0004\|aa\|000\|000\|([0-9a-f]{2}\|){5}25\.00\|$' "$WORK/recs.txt" ||
  fail "no master transmit record: $(head -3 "$WORK/recs.txt")"
grep -qE '^\|000[1-6]\|A\|1001\|bb\|[0-9]{3}\|[0-9]{3}\|([0-9a-f]{2}\|){5}25\.00\|(0\|){8}$' \
  "$WORK/recs.txt" || fail "no blink record: $(head -3 "$WORK/recs.txt")"
echo "ok: --to-records wrote $n records; ids ${IDS[*]}"

lcm-logger -q -f -c '^(UWB_RX_TCP|UWB_RX_UDP|UWB_RX_FILE|UWB_RX_STDIN|UWB_RX_POWER|HEALTH|IPS_BUS_CHECK_[0-9]+)$' "$WORK/out.lcm" &
logger=$!; pids+=($logger)
logger_sync "$WORK/out.lcm"
# health_wait ARGS...: until the recording holds a HEALTH of the driver as ARGS ask (at most 60 s).
health_wait() {
  python3 "$HERE/../health_wait.py" "$WORK/out.lcm" --source ips-uwb-tdoa-anchors "$@"
}

# --- 2: TCP, the server starting late and going away once -----------------------------------
half=$((n / 2))
t0=$(now_us)
"$DRV" --tcp 127.0.0.1:47001 "${IDS[@]}" --channel UWB_RX=UWB_RX_TCP --log-level warn \
  2> "$WORK/tcp.err" &
drv=$!; pids+=($drv)
sleep 0.4  # not there yet: refused, retried
python3 "$HERE/anchor_server.py" tcp 47001 "$WORK/recs.txt" "$half" 1.5 "$WORK/tcp.done" &
srv=$!; pids+=($srv)
for _ in $(seq 1200); do [ -e "$WORK/tcp.done" ] && break; sleep 0.05; done
[ -e "$WORK/tcp.done" ] || fail "the TCP server did not finish: $(cat "$WORK/tcp.err")"
# The records, then one OK HEALTH after the reconnect that counts them all.
health_wait --state 0 --msgs-in "$n" --after "$t0" || fail "--tcp: $(cat "$WORK/tcp.err")"
kill -INT $drv; rc=0; wait $drv || rc=$?
[ "$rc" -eq 0 ] || fail "--tcp: exit status $rc after SIGINT: $(cat "$WORK/tcp.err")"
wait $srv || true
t1=$(now_us)
grep -q "reconnecting" "$WORK/tcp.err" || fail "--tcp: no reconnect warning: $(cat "$WORK/tcp.err")"

# --- 3: UDP datagrams, then bad ones -----------------------------------------------------------
printf '%s\n' 'not a record' '|0006|A|1007|cc|000|084|60|75|7d|3f|e2|67.80|0|0|0|0|0|0|0|0|' \
  > "$WORK/bad_datagrams.txt"
t2=$(now_us)
"$DRV" --udp 127.0.0.1:47002 "${IDS[@]}" --channel UWB_RX=UWB_RX_UDP --log-level error &
drv=$!; pids+=($drv)
wait_udp_bound 47002
python3 "$HERE/anchor_server.py" udp 47002 "$WORK/recs.txt" "$WORK/bad_datagrams.txt"
health_wait --msgs-in $((n + 2)) --after "$t2" || fail "--udp: a datagram was not counted"
kill -TERM $drv; rc=0; wait $drv || rc=$?
[ "$rc" -eq 0 ] || fail "--udp: exit status $rc after SIGTERM"
t3=$(now_us)

# --- 4: a file with garbled records mixed in, and stdin ------------------------------------------
{
  sed -n '1,40p' "$WORK/recs.txt"
  echo 'garbage that is no record'
  echo '|0006|X|1007|bb|000|084|60|75|7d|3f|e2|67.80|0|0|0|0|0|0|0|0|'      # flag X
  echo '|0006|A|1007|bb|000|084|60|75|7g|3f|e2|67.80|0|0|0|0|0|0|0|0|'      # not hex
  echo '|0006|A|1007|bb|000|084|60|75|7d|3f|e2|nan|0|0|0|0|0|0|0|0|'        # NaN
  echo '|0006|A|1007|bb|000|084|60|75|7d'                                    # cut short
  echo ''                                                                    # blank: nothing
  head -c 1000 /dev/zero | tr '\0' 'x'; echo                                 # overlong
  echo '|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|'                       # 8 values missing
  sed -n '41,$p' "$WORK/recs.txt"
} > "$WORK/bad.txt"
"$DRV" --file "$WORK/bad.txt" --rate 500 "${IDS[@]}" --channel UWB_RX=UWB_RX_FILE \
  --log-level error || fail "--file exited with $?"
t4=$(now_us)
cat "$WORK/recs.txt" | "$DRV" --file - "${IDS[@]}" --channel UWB_RX=UWB_RX_STDIN --rate 500 \
  --log-level error || fail "--file - exited with $?"
t5=$(now_us)
# 004's three examples with --rx-power: the DW1000 reading of their diagnostics.
printf '%s\n' '|0001|E|0001|aa|034|136|3b|3e|87|fe|b5|57.63|' \
  '|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|218|2301|12|3084|2470|218|237|744.3593|' \
  '|0006|A|0001|aa|034|136|61|15|93|d9|b5|67.80|184|1888|12|1967|1693|269|240|744.2812|' \
  > "$WORK/examples.txt"
"$DRV" --file "$WORK/examples.txt" --rx-power dw1000-prf64 --channel UWB_RX=UWB_RX_POWER \
  --log-level error || fail "--file --rx-power exited with $?"

logger_sync "$WORK/out.lcm"
kill -INT $logger; wait $logger || true; pids=()

python3 - "$WORK/sim.lcm" "$WORK/out.lcm" "$n" "$t0 $t1 $t2 $t3 $t3 $t4 $t4 $t5" <<'PY' ||
import math, sys, lcm_log, lcm_messages
sim_path, out_path, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
t = [int(x) for x in sys.argv[4].split()]
windows = {'UWB_RX_TCP': t[0:2], 'UWB_RX_UDP': t[2:4], 'UWB_RX_FILE': t[4:6], 'UWB_RX_STDIN': t[6:8]}
sim = [lcm_messages.uwb_rx(d) for ch, _, d in lcm_log.events(sim_path)[0] if ch == 'UWB_RX']
out, _, _ = lcm_log.events(out_path)
assert len(sim) == n, (len(sim), n)
sources = {'UWB_RX_TCP': 'ips-uwb-tdoa-anchors:tcp:127.0.0.1:47001',
           'UWB_RX_UDP': 'ips-uwb-tdoa-anchors:udp:127.0.0.1:47002',
           'UWB_RX_STDIN': 'ips-uwb-tdoa-anchors:stdin'}

# What lcm-logger recorded: the simulator's messages in order. At hundreds a second the real
# lcm-logger (liblcm's default queue of 30 messages) misses some when a loaded machine holds it
# up: those may be missing (at most 5 %), none may differ or be out of order. That every record
# was published is the driver's own count (HEALTH msgs_out, below).
for name, (lo, hi) in windows.items():
    got = [lcm_messages.uwb_rx(d) for c, _, d in out if c == name]
    assert len(sim) - len(sim) // 20 <= len(got) <= len(sim), \
        f'{name}: {len(got)} recorded, {len(sim)} in the sim log'
    j = 0
    for i, b in enumerate(got):
        while j < len(sim) and (sim[j]['anchor_id'], sim[j]['sender_id'], sim[j]['rx_counter']) != \
                (b['anchor_id'], b['sender_id'], b['rx_counter']):
            j += 1
        assert j < len(sim), f'{name} #{i}: {b} is not the next of the simulator\'s messages'
        a = sim[j]
        j += 1
        where = f'{name} #{i}: {a} vs {b}'
        for k in ('anchor_id', 'sender_id', 'is_sync', 'seq', 'rx_counter', 'counter_hz'):
            assert a[k] == b[k], f'{k}: {where}'
        assert math.isnan(b['rx_power_dbm']) and math.isnan(b['fp_power_dbm']), where
        assert math.isnan(b['quality']), where
        assert lo <= b['utime'] <= hi, f'{where}: not host time in [{lo}, {hi}]'
        if name in sources:
            assert b['source'] == sources[name], where
    missed = len(sim) - len(got)
    print(f'ok: {name}: {len(got)} messages equal to the simulator\'s, host times'
          + (f' ({missed} missed by lcm-logger)' if missed else ''))

# HEALTH of each run (by pid, in time order): TCP, UDP, file, stdin.
runs = {}
for c, _, d in out:
    if c == 'HEALTH':
        h = lcm_messages.health(d)
        if h['source'] == 'ips-uwb-tdoa-anchors':
            runs.setdefault(h['pid'], []).append(h)
assert len(runs) == 5, f'HEALTH from {len(runs)} runs (expected 5)'
tcp, udp, file_, stdin, _ = sorted(runs.values(), key=lambda hs: hs[0]['utime'])
gone = [h for h in tcp if h['state'] == 1 and 'reconnecting' in h['last_error']]
assert gone, f'no degraded HEALTH while the server was away: {tcp}'
assert any('closed the connection' in h['last_error'] for h in gone), gone
assert any(h['msgs_out'] == n // 2 for h in gone), f'first half not all out while away: {gone}'
last = tcp[-1]
assert last['state'] == 0 and last['msgs_in'] == n and last['msgs_out'] >= n, last
assert last['parse_errors'] == 0 and last['drops'] == 0, last
print(f'ok: TCP HEALTH: degraded while away ({gone[0]["last_error"]!r}), OK after, {n} in')
last = udp[-1]
assert last['parse_errors'] == 2 and last['msgs_in'] == n + 2 and last['drops'] == 0, last
assert last['msgs_out'] >= n, last
assert last['state'] == 1 and 'cc' in last['last_error'], last
print(f'ok: UDP HEALTH: {last["parse_errors"]} parse errors ({last["last_error"]!r})')
last = file_[-1]
assert last['parse_errors'] == 7 and last['msgs_in'] == n + 6 and last['msgs_out'] >= n, last
print(f'ok: file HEALTH: {last["parse_errors"]} parse errors ({last["last_error"]!r})')
last = stdin[-1]
assert last['parse_errors'] == 0 and last['msgs_in'] == n and last['state'] == 0, last
assert last['msgs_out'] >= n, last

# DW1000 user manual 4.7.2 at 64 MHz PRF on 004's examples (see anchor_report_parser_test.cpp).
ex = [lcm_messages.uwb_rx(d) for c, _, d in out if c == 'UWB_RX_POWER']
assert [(m['anchor_id'], m['sender_id'], m['seq'], m['rx_counter']) for m in ex] == [
    ('0001', '0001', 34136, 0x3b3e87feb5), ('0006', '1007', 84, 0x60757d3fe2),
    ('0006', '0001', 34136, 0x611593d9b5)], ex
assert math.isnan(ex[0]['rx_power_dbm']) and math.isnan(ex[0]['fp_power_dbm']), ex[0]
for m, rx, fp in ((ex[1], -94.6753, -96.0321), (ex[2], -93.8716, -99.2159)):
    assert abs(m['rx_power_dbm'] - rx) < 1e-3 and abs(m['fp_power_dbm'] - fp) < 1e-3, m
print('ok: --rx-power dw1000-prf64 on the examples of source 004')
PY
  fail "published messages differ"
echo PASS
