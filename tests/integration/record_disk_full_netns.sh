#!/usr/bin/env bash
# ips-record on a disk that fills up, for real: an 8 MiB tmpfs in a private mount namespace, live
# traffic over real LCM multicast in a private network namespace, --min-free-mb 0.
#  1. a simulator (A) publishes; ips-record records; the disk is filled (dd until ENOSPC);
#  2. the sidecar (rewritten in place, as no new file fits) and HEALTH say "paused: disk full"
#     with the count of messages not written so far; the log on the full disk reads back whole;
#  3. the filler is removed: recording resumes by itself, the pause's start, end and losses are
#     in the sidecar and in HEALTH;
#  4. a second simulator run (B) is recorded in full after the resume; SIGINT ends with 0;
#  5. the log reads back with no damage (our reader, an independent one, lcm-logplayer); per
#     channel, what A published = what was recorded before the pause + the losses counted + what
#     was recorded after it (a prefix and a suffix of A's messages, in order).
# Exit 77 (skipped) when no mount or network namespace can be made, or tmpfs cannot be mounted.
set -euo pipefail
# A private mount namespace first (the tmpfs is gone with it), then the network one.
if [ "${IPS_IN_MNTNS:-}" != "1" ]; then
  if [ "$(id -u)" -eq 0 ]; then mnt_args=(--mount); else mnt_args=(--user --map-root-user --mount); fi
  if ! unshare "${mnt_args[@]}" true 2>/dev/null; then
    echo "skip: cannot create a mount namespace here (need root or user namespaces)" >&2
    exit 77
  fi
  IPS_IN_MNTNS=1 exec unshare "${mnt_args[@]}" "$0" "$@"
fi
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
START_A=1767225600000000
START_B=1768089600000000  # ten days later: B's messages are told from A's by their utime
DISK=$WORK/disk
mkdir -p "$DISK"
if ! mount -t tmpfs -o size=8m tmpfs "$DISK" 2>"$WORK/mount.err"; then
  echo "skip: cannot mount a tmpfs here: $(cat "$WORK/mount.err")" >&2
  exit 77
fi
trap 'umount -l "$DISK" 2>/dev/null || true; cleanup' EXIT

# poll.py WHAT: waits (at most 60 s, every 0.1 s) until the condition WHAT holds; prints it.
cat >"$WORK/poll.py" <<'PY'
import json, os, re, struct, sys, time
import lcm_log
what, side, health_log = sys.argv[1], sys.argv[2], sys.argv[3]

def sidecar():
    try:
        return json.load(open(side))
    except (OSError, ValueError):
        return None  # being replaced, or (in place) half rewritten: read again

def healths():
    out = []
    for c, _, d in lcm_log.events(health_log)[0] if os.path.exists(health_log) else []:
        i = 16
        def s():
            nonlocal i
            n = struct.unpack_from('>i', d, i)[0]
            v = d[i + 4:i + 3 + n].decode('utf-8', 'replace')
            i += 4 + n
            return v
        source, _ = s(), s()
        pid, state = struct.unpack_from('>ib', d, i)
        i += 5 + 32
        if source == 'ips-record':
            out.append(dict(state=state, drops=struct.unpack_from('>q', d, i - 8)[0],
                            last_error=s()))
    return out

deadline = time.time() + 60
while True:
    j, h = sidecar(), healths()
    last = h[-1] if h else None
    if what == 'paused':
        ok = j and j['state'] == 'paused' and j['disk']['paused']['not_written'] > 0 and \
            j['recording'] is False
        got = j and j['disk']
    elif what == 'health-paused':
        ok = last and last['state'] == 2 and 'paused: disk full' in last['last_error'] and \
            int((re.search(r': (\d+) messages not written so far$', last['last_error'])
                 or [0, 0])[1]) > 0
        got = last
    elif what == 'resumed':
        ok = j and j['state'] == 'recording' and j['disk']['paused'] is None and \
            len(j['disk']['pauses']) == 1 and j['disk']['pauses'][0]['end'] is not None
        got = j and j['disk']
    elif what == 'health-resumed':
        ok = last and last['state'] != 2 and \
            last['last_error'].startswith('resumed after disk full (No space left on device): ') and \
            ' messages lost from ' in last['last_error']
        got = last
    if ok:
        print(f'ok: {what}: {got}')
        break
    if time.time() > deadline:
        sys.exit(f'FAIL: not {what} within 60 s: {got}')
    time.sleep(0.1)
PY
poll() { python3 "$WORK/poll.py" "$1" "$DISK/s.json" "$WORK/health.lcm" || fail "$1"; }

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
"$BIN/ips-sim" --scenario lab --seed 1 --duration 120 --start-utime $START_A --out "$WORK/refA.lcm" \
  --log-level warn
"$BIN/ips-sim" --scenario lab --seed 2 --duration 10 --start-utime $START_B --out "$WORK/refB.lcm" \
  --log-level warn
lcm-logger -q -c HEALTH "$WORK/health.lcm" & logger=$!; pids+=($logger)

# --- 1: recording, then the disk fills ----------------------------------------------------------
"$BIN/ips-record" --out "$DISK/s.lcm" --min-free-mb 0 --site-wait 30 --flush-ms 50 \
  --log-level warn 2>"$WORK/record.err" & rec=$!; pids+=($rec)
"$BIN/ips-bus-check" --wait-for ips-record --timeout 60 || fail "ips-record did not come up"
# 120 s of the lab at 4x: 30 s, about 4.9 MB; the pause and the resume take a few seconds of it.
"$BIN/ips-sim" --scenario lab --seed 1 --duration 120 --speed 4 --start-utime $START_A \
  --log-level warn & simA=$!; pids+=($simA)
python3 "$HERE/log_wait.py" "$DISK/s.lcm" --events 500 --pid $rec
dd if=/dev/zero of="$DISK/filler" bs=64k status=none 2>/dev/null || true
echo "ok: the disk is full: $(df -k "$DISK" | tail -1)"

# --- 2: paused, and says so ---------------------------------------------------------------------
poll paused
poll health-paused
python3 - "$DISK/s.lcm" <<'PY' || fail "the log on the full disk"
import sys, lcm_log
evs, used, size = lcm_log.events(sys.argv[1])
assert used == size, f'unreadable from byte {used} of {size} (an event cut short by the full disk)'
print(f'ok: the log on the full disk ends on a complete event ({len(evs)} events, {size} bytes)')
PY

# --- 3: space returns ---------------------------------------------------------------------------
rm -f "$DISK/filler"
poll resumed
poll health-resumed
kill -0 $rec || fail "ips-record exited: $(cat "$WORK/record.err")"

# --- 4: B is recorded in full after the resume -------------------------------------------------
wait $simA || fail "ips-sim (A) failed"; forget $simA
"$BIN/ips-sim" --scenario lab --seed 2 --duration 10 --speed 4 --start-utime $START_B --log-level warn
python3 "$HERE/log_wait.py" "$DISK/s.lcm" --last-of "$WORK/refB.lcm" --pid $rec
stop $rec ips-record
kill -INT $logger; wait $logger || true; forget $logger
grep -q "paused: disk full (No space left on device)" "$WORK/record.err" ||
  fail "ips-record did not log the pause: $(cat "$WORK/record.err")"
grep -q "resumed after disk full" "$WORK/record.err" ||
  fail "ips-record did not log the resume: $(cat "$WORK/record.err")"

# --- 5: the log, the counts ---------------------------------------------------------------------
python3 - "$DISK/s.lcm" "$DISK/s.json" "$WORK/refA.lcm" "$WORK/refB.lcm" $START_B <<'PY' || fail "the log and the sidecar after the pause"
import collections, json, struct, sys, lcm_log
log, side_path, ref_a, ref_b, start_b = sys.argv[1:4] + [sys.argv[4], int(sys.argv[5])]
evs, used, size = lcm_log.events(log)
assert used == size, f'unreadable from byte {used} of {size}'
side = json.load(open(side_path))
assert side['state'] == 'stopped' and side['stopped_by'] == 'SIGINT', side
assert side['events'] == len(evs) and side['bytes'] == size, (side['events'], len(evs), side['bytes'], size)
disk = side['disk']
assert disk['paused'] is None and len(disk['pauses']) == 1, disk
p = disk['pauses'][0]
assert p['reason'] == 'disk full (No space left on device)', p
assert p['end_utime'] > p['start_utime'] and p['lost'] == disk['lost'] > 0, p
lost = {ch: c['lost_disk'] for ch, c in side['channels'].items()}
assert sum(lost.values()) == disk['lost'], (lost, disk['lost'])
def utime(d):
    return struct.unpack('>q', d[8:16])[0]
def by_channel(events, keep):
    out = collections.defaultdict(list)
    for ch, _, d in events:
        if ch != 'HEALTH' and not ch.startswith('IPS_BUS_CHECK') and keep(d):
            out[ch].append(d)
    return out
# The head of the file repeats the bus's SITE when other messages (HEALTH) came before it.
assert evs[0][0] == 'SITE', evs[0][0]
body = evs[1:] if any(c == 'SITE' and d == evs[0][2] for c, _, d in evs[1:]) else evs
got_a = by_channel(body, lambda d: utime(d) < start_b)
got_b = by_channel(body, lambda d: utime(d) >= start_b)
want_a = by_channel(lcm_log.events(ref_a)[0], lambda d: True)
want_b = by_channel(lcm_log.events(ref_b)[0], lambda d: True)
assert got_b == want_b, 'B (after the resume) not recorded whole and in order'
total_lost = 0
for ch, want in want_a.items():
    got, n_lost = got_a.get(ch, []), lost.get(ch, 0)
    assert len(got) + n_lost == len(want), f'{ch}: {len(got)} recorded + {n_lost} lost != {len(want)} published'
    k = next(i for i in range(len(got) + 1) if i == len(got) or got[i] != want[i])
    suffix = got[k:]
    assert suffix == want[len(want) - len(suffix):], \
        f'{ch}: after the gap the recording is not the end of what was published'
    total_lost += n_lost
# The pause's time span is the gap in the receive times of the log.
t = [ts for _, ts, _ in evs]
gap = max(b - a for a, b in zip(t, t[1:]))
assert gap <= p['end_utime'] - p['start_utime'] + 2_000_000, (gap, p)
print(f'ok: {len(evs)} events read back whole; {disk["lost"]} messages lost in a pause of '
      f'{(p["end_utime"] - p["start_utime"]) / 1e6:.1f} s ({total_lost} of the simulator\'s), '
      f'each channel = the recorded prefix + the losses + the recorded suffix; B recorded whole')
PY
"$BIN/ips-export" "$DISK/s.lcm" --out "$WORK/csv" 2>"$WORK/export.err" || fail "ips-export: $(cat "$WORK/export.err")"
if grep -q "warning" "$WORK/export.err"; then fail "ips-export warns about the log: $(cat "$WORK/export.err")"; fi
n=$(python3 -c "import sys, lcm_log; print(len(lcm_log.events(sys.argv[1])[0]))" "$DISK/s.lcm")
played=$(lcm-logplayer -v -s 1000 "$DISK/s.lcm" 2>&1 | grep -c 'Channel ')
[ "$played" -eq "$n" ] || fail "lcm-logplayer published $played of $n events"
echo "ok: ips-export reads the log without a warning; lcm-logplayer plays all $n events"
