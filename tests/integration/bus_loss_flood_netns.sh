#!/usr/bin/env bash
# A flood the receiver cannot keep up with is reported, never silent (real LCM multicast in a
# private network namespace): tests/integration/lcm_flood.py sends 200 000 small ble_aoa_t as
# fast as it can at an ips-record whose receive buffer is small (recv_buf_size=8192 in its URL).
# The kernel drops datagrams; then ips-record's HEALTH shows kernel_drops > 0 and the state
# degraded with the reason, its sidecar's "loss" agrees with the sender's count (recorded + lost
# = sent, up to the few HEALTH messages lost alike), and the sequence-gap count equals exactly
# the flood messages missing from the recording. Exit 77 (skipped) when no network namespace can
# be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
COUNT=200000

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
"$BIN/ips-sim" --scenario aoa-hall --duration 1 --out "$WORK/aoa.lcm" --log-level warn
"$BIN/ips-record" --out "$WORK/rec.lcm" --site-wait 0 --log-level warn \
  --lcm-url "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8192" 2>"$WORK/record.err" &
rec=$!; pids+=($rec)
"$BIN/ips-bus-check" --wait-for ips-record --timeout 60 || fail "ips-record did not come up"
probes() { { grep -ao 'IPS_BUS_CHECK_' "$WORK"/rec*.lcm 2>/dev/null || true; } | wc -l; }
sync_probe() {  # a probe recorded after everything sent before it (or lost)
  local deadline=$((SECONDS + 60)) n0 i
  n0=$(probes)
  while [ "$SECONDS" -lt "$deadline" ]; do
    "$BIN/ips-bus-check" --timeout 30 >/dev/null || fail "multicast does not loop back"
    for i in $(seq 40); do
      [ "$(probes)" -gt "$n0" ] && return 0
      sleep 0.05  # ips-record flushes every 100 ms
    done
  done
  fail "ips-record recorded no probe within 60 s"
}
sent=$(python3 "$HERE/lcm_flood.py" "$WORK/aoa.lcm" $COUNT)
sync_probe
# One more, numbered after the flood, once the buffer is empty: the gap counter then sees every
# flood message lost, the last ones too.
sent=$((sent + $(python3 "$HERE/lcm_flood.py" "$WORK/aoa.lcm" 1 $COUNT)))
sync_probe
# Until a HEALTH of ips-record stamped after the flood reports the kernel's drops.
python3 - "$WORK" <<'PY' || fail "no HEALTH of ips-record reported the flood's drops within 60 s"
import glob, os, sys, time
import lcm_log, lcm_messages
deadline = time.time() + 60
while time.time() < deadline:
    for p in glob.glob(os.path.join(sys.argv[1], 'rec*.lcm')):
        for c, _, d in lcm_log.events(p)[0]:
            if c != 'HEALTH':
                continue
            h = lcm_messages.health(d)
            if h['source'] == 'ips-record' and h['kernel_drops'] > 0:
                assert h['state'] == 1, h  # degraded
                assert 'lost on the way in' in h['last_error'], h
                assert h['recv_buf_bytes'] < 65536, h
                print(f"HEALTH: kernel_drops {h['kernel_drops']}, queue_drops {h['queue_drops']}, "
                      f"seq_lost {h['seq_lost']}, state degraded: {h['last_error']}")
                sys.exit(0)
    time.sleep(0.2)
sys.exit(1)
PY
stop $rec ips-record
python3 - "$WORK" "$sent" $((COUNT + 1)) <<'PY' || fail "the flood's loss is not accounted for"
import glob, json, os, sys
import lcm_log
work, sent, numbered = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
assert sent == numbered, f'the sender sent {sent} of {numbered}'
rec = []
for p in sorted(glob.glob(os.path.join(work, 'rec*.lcm'))):
    rec += lcm_log.events(p)[0]
flood = sum(1 for c, _, _ in rec if c == 'BLE_AOA')
side = json.load(open(os.path.join(work, 'rec.json')))
loss = side['loss']
missing = sent - flood
print(f'flood: sent {sent}, recorded {flood}, missing {missing}; sidecar: kernel_drops '
      f'{loss["kernel_drops"]}, queue_drops {loss["queue_drops"]}, dropped {side["dropped"]}, '
      f'seq_lost {loss["seq_lost"]}, recv_buf_bytes {loss["recv_buf_bytes"]}')
assert missing > 0, 'the flood lost nothing: the test provoked no drop'
assert loss['kernel_drops'] > 0, loss
assert loss['seq_lost'] == missing, f'seq_lost {loss["seq_lost"]} != {missing} missing'
lost = loss['lost'] + side['dropped']
assert missing <= lost <= missing + 20, f'{lost} reported lost, {missing} missing'
PY
echo "ok: a flood's loss is reported in HEALTH and the sidecar"
