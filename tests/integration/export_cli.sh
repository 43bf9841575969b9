#!/usr/bin/env bash
# ips-export on real files: a simulated lab log exported to CSV and JSON lines (headers, one row
# per message per channel, every CSV rectangular, every JSON line valid with NaN as null), the
# channel and time filters, and damaged inputs: a log cut short, garbage in the middle, a channel
# of unknown type, an empty file, a text file, an output directory that cannot be created; events
# on an empty channel (legal LCM) counted and skipped, not damage.
set -uo pipefail
BIN=$(cd "$1" && pwd)
export PYTHONPATH=$(cd "$(dirname "$0")" && pwd)  # lcm_log.py
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}
ok() { echo "ok: $*"; }

# Counts events with the independent Python reader of the log format (lcm_log.py): prints
# "CHANNEL COUNT" per channel. Optional 2nd/3rd args: a time window in s.
count_events() {
  python3 - "$@" <<'PY'
import collections, sys, lcm_log
evs, _, _ = lcm_log.events(sys.argv[1])
lo = float(sys.argv[2]) if len(sys.argv) > 2 else None
hi = float(sys.argv[3]) if len(sys.argv) > 3 else None
counts = collections.Counter()
for ch, ts, _ in evs:
    t = (ts - evs[0][1]) * 1e-6
    if (lo is None or t >= lo) and (hi is None or t <= hi):
        counts[ch] += 1
for ch, n in sorted(counts.items()):
    print(ch, n)
PY
}

# Every CSV parses (quotes respected) with as many fields per row as the header; every JSONL line
# is strict JSON (no NaN). Prints "STEM CSV_ROWS JSONL_LINES" per channel.
check_files() {
  python3 - "$1" <<'PY'
import csv, glob, json, os, sys
d = sys.argv[1]
stems = sorted({os.path.splitext(os.path.basename(p))[0] for p in glob.glob(d + '/*.csv') + glob.glob(d + '/*.jsonl')})
def strict(x):
    raise ValueError('non-JSON constant ' + x)
for s in stems:
    rows = lines = -1
    if os.path.exists(f'{d}/{s}.csv'):
        with open(f'{d}/{s}.csv', newline='') as f:
            r = list(csv.reader(f))
        bad = [i for i, row in enumerate(r) if len(row) != len(r[0])]
        if bad:
            sys.exit(f'{s}.csv: row {bad[0]} has {len(r[bad[0]])} fields, header {len(r[0])}')
        rows = len(r) - 1
    if os.path.exists(f'{d}/{s}.jsonl'):
        lines = 0
        for line in open(f'{d}/{s}.jsonl'):
            o = json.loads(line, parse_constant=strict)
            assert o["channel"] == s, (o["channel"], s)
            lines += 1
    print(s, rows, lines)
PY
}

# run STATUS CMD...: runs CMD, checks its exit status; stderr in $WORK/err, stdout in $WORK/out.
run() {
  local want=$1 status=0
  shift
  timeout 60 "$@" >"$WORK/out" 2>"$WORK/err" || status=$?
  if [ "$status" -ne "$want" ]; then
    fail "$* -> status $status (want $want)"
    sed 's/^/  stderr: /' "$WORK/err" | head -10
    return 1
  fi
}

"$BIN/ips-sim" --scenario lab --duration 5 --out "$WORK/lab.lcm" --log-level warn || exit 1

# 1. The whole log: one CSV row and one JSON line per message, per channel (SITE: one row per
#    site element, so at least one per message).
if run 0 "$BIN/ips-export" "$WORK/lab.lcm" --out "$WORK/all"; then
  [ -s "$WORK/err" ] && fail "full export wrote to stderr: $(head -3 "$WORK/err")"
  count_events "$WORK/lab.lcm" >"$WORK/want"
  check_files "$WORK/all" >"$WORK/got" || fail "output files do not parse"
  while read -r ch n; do
    read -r _ rows lines < <(grep "^$ch " "$WORK/got")
    if [ "$ch" = SITE ]; then
      [ "${lines:-0}" -eq "$n" ] && [ "${rows:-0}" -ge "$n" ] || fail "SITE: $n messages, $rows rows, $lines lines"
    else
      [ "${lines:-0}" -eq "$n" ] && [ "${rows:-0}" -eq "$n" ] || fail "$ch: $n messages, $rows rows, $lines lines"
    fi
  done <"$WORK/want"
  [ "$(wc -l <"$WORK/want")" -eq "$(wc -l <"$WORK/got")" ] || fail "channels: $(cat "$WORK/want") vs $(cat "$WORK/got")"
  [ "$(head -1 "$WORK/all/UWB_RANGE.csv")" = \
    "utime_us,source,tag_id,anchor_id,range_m,rx_power_dbm,fp_power_dbm,quality,seq" ] ||
    fail "UWB_RANGE header: $(head -1 "$WORK/all/UWB_RANGE.csv")"
  head -1 "$WORK/all/TRUTH.csv" | grep -q "^utime_us,source,tag_id,position_x_m,position_y_m,position_z_m,position_cov_xx_m2," ||
    fail "TRUTH header: $(head -1 "$WORK/all/TRUTH.csv")"
  # No field of the simulated log holds a comma: a plain awk count agrees too.
  awk -F, 'FNR == 1 { n = NF } NF != n { bad = 1 } END { exit bad }' "$WORK"/all/*.csv || fail "awk column count"
  ok "full export: $(tr '\n' ' ' <"$WORK/got")"
fi

# 2. Channel filter (full match) and formats.
if run 0 "$BIN/ips-export" "$WORK/lab.lcm" --out "$WORK/uwb" --channels 'UWB_.*' --format csv; then
  got=$(cd "$WORK/uwb" && ls | tr '\n' ' ')
  [ "$got" = "UWB_RANGE.csv UWB_RX.csv " ] && ok "--channels 'UWB_.*' --format csv: $got" || fail "--channels: $got"
fi
if run 0 "$BIN/ips-export" "$WORK/lab.lcm" --out "$WORK/none" --channels 'UWB'; then
  [ -z "$(ls "$WORK/none")" ] && ok "--channels is a full match" || fail "--channels UWB matched: $(ls "$WORK/none")"
fi

# 3. Time range, relative to the first event.
if run 0 "$BIN/ips-export" "$WORK/lab.lcm" --out "$WORK/t" --from 1 --to 2.5 --format jsonl; then
  count_events "$WORK/lab.lcm" 1 2.5 >"$WORK/want"
  check_files "$WORK/t" | awk '{ print $1, $3 }' >"$WORK/got"
  diff "$WORK/want" "$WORK/got" >/dev/null && ok "--from 1 --to 2.5: $(tr '\n' ' ' <"$WORK/got")" ||
    fail "--from/--to: want $(cat "$WORK/want") got $(cat "$WORK/got")"
fi

# 4. Damaged inputs: each reported, what is readable exported, exit 0.
head -c 20000 "$WORK/lab.lcm" >"$WORK/cut.lcm"
if run 0 "$BIN/ips-export" "$WORK/cut.lcm" --out "$WORK/cut"; then
  grep -Eq "read [0-9]+ events, then stopped at byte [0-9]+ of 20000" "$WORK/err" &&
    [ "$(cat "$WORK"/cut/*.jsonl | wc -l)" -gt 0 ] && ok "cut log: $(cat "$WORK/err")" || fail "cut log: $(cat "$WORK/err")"
fi
size=$(stat -c %s "$WORK/lab.lcm")
{ head -c $((size / 2)) "$WORK/lab.lcm"; python3 "$(dirname "$0")/lcm_log.py" garbage 3000; tail -c +$((size / 2 + 1)) "$WORK/lab.lcm"; } >"$WORK/garbage.lcm"
if run 0 "$BIN/ips-export" "$WORK/garbage.lcm" --out "$WORK/garbage"; then
  n=$(cat "$WORK"/garbage/*.jsonl | wc -l)
  total=$(count_events "$WORK/lab.lcm" | awk '{ s += $2 } END { print s }')
  # The event the garbage landed in may be lost, the rest is there.
  if grep -Eq "skipped [0-9]+ damaged bytes in 1 places and read on" "$WORK/err" && [ "$n" -ge $((total - 2)) ]; then
    ok "garbage in the middle: $n of $total messages; $(tr '\n' ' ' <"$WORK/err")"
  else
    fail "garbage in the middle: $n of $total messages; stderr: $(cat "$WORK/err")"
  fi
fi
: >"$WORK/empty.lcm"
run 0 "$BIN/ips-export" "$WORK/empty.lcm" --out "$WORK/empty" &&
  { grep -q "is empty" "$WORK/err" && ok "empty log: $(cat "$WORK/err")" || fail "empty log: $(cat "$WORK/err")"; }

# A channel of a type that is not ips's: skipped, counted, named.
python3 - "$WORK/lab.lcm" "$WORK/foreign.lcm" <<'PY'
import struct, sys
data = open(sys.argv[1], 'rb').read()
def event(n, ts, ch, payload):
    ch = ch.encode()
    return struct.pack('>IqqII', 0xEDA1DA01, n, ts, len(ch), len(payload)) + ch + payload
extra = b''.join(event(100000 + i, 1767225600000000 + i, 'FOREIGN', bytes(range(40))) for i in range(3))
open(sys.argv[2], 'wb').write(data + extra)
PY
if run 0 "$BIN/ips-export" "$WORK/foreign.lcm" --out "$WORK/foreign"; then
  grep -q "skipped 3 messages of no known type.*FOREIGN (3)" "$WORK/err" && [ ! -e "$WORK/foreign/FOREIGN.csv" ] &&
    ok "unknown type: $(cat "$WORK/err")" || fail "unknown type: $(cat "$WORK/err")"
fi

# Events on an empty channel are legal LCM events: counted and skipped, not damage.
python3 - "$WORK/lab.lcm" "$WORK/empty_channel.lcm" <<'PY'
import struct, sys
data = open(sys.argv[1], 'rb').read()
def event(n, ts, ch, payload):
    ch = ch.encode()
    return struct.pack('>IqqII', 0xEDA1DA01, n, ts, len(ch), len(payload)) + ch + payload
i, cut = 0, len(data) // 2
while i < cut:  # to the event boundary after the middle
    cl, dl = struct.unpack('>II', data[i + 20:i + 28])
    i += 28 + cl + dl
extra = b''.join(event(200000 + k, 1767225600000000 + k, '', bytes(range(k * 10))) for k in range(3))
open(sys.argv[2], 'wb').write(data[:i] + extra + data[i:])
PY
if run 0 "$BIN/ips-export" "$WORK/empty_channel.lcm" --out "$WORK/empty_channel"; then
  count_events "$WORK/lab.lcm" >"$WORK/want"
  check_files "$WORK/empty_channel" | awk '{ print $1, $3 }' >"$WORK/got"
  if grep -q "empty_channel.lcm: 3 events on an empty channel, skipped" "$WORK/err" &&
    ! grep -q "damaged\|cut short\|warning" "$WORK/err" &&
    grep -q "3 on an empty channel (skipped)" "$WORK/out" && diff "$WORK/want" "$WORK/got" >/dev/null; then
    ok "empty channel: $(cat "$WORK/err")"
  else
    fail "empty channel: stderr: $(cat "$WORK/err"); stdout: $(tail -1 "$WORK/out"); $(diff "$WORK/want" "$WORK/got" | head -3)"
  fi
fi

# 5. Errors: one line, status 2.
expect_error() {
  local pattern=$1
  shift
  if run 2 "$@"; then
    [ "$(wc -l <"$WORK/err")" -eq 1 ] && grep -Eq -- "$pattern" "$WORK/err" && ok "$* -> $(cat "$WORK/err")" ||
      fail "$*: stderr: $(cat "$WORK/err")"
  fi
}
echo "just text, not a log" >"$WORK/text.lcm"
expect_error "^ips-export: error: '.*text.lcm' is not an LCM log \(no readable event\)$" \
  "$BIN/ips-export" "$WORK/text.lcm" --out "$WORK/text"
expect_error "^ips-export: error: cannot write to output directory '.*/text.lcm/sub'" \
  "$BIN/ips-export" "$WORK/lab.lcm" --out "$WORK/text.lcm/sub"
expect_error "^ips-export: error: cannot read log '/nonexistent.lcm'" "$BIN/ips-export" /nonexistent.lcm --out "$WORK/x"
expect_error "^ips-export: error: --channels '\(': " "$BIN/ips-export" "$WORK/lab.lcm" --out "$WORK/x" --channels '('
expect_error "^ips-export: error: --from/--to" "$BIN/ips-export" "$WORK/lab.lcm" --out "$WORK/x" --from 3 --to 1
expect_error "^ips-export: error: .*--format" "$BIN/ips-export" "$WORK/lab.lcm" --out "$WORK/x" --format xml
if "$BIN/ips-export" --help >"$WORK/out" 2>"$WORK/err" && grep -q -- "--log-level" "$WORK/out" && [ ! -s "$WORK/err" ]; then
  ok "--help"
else
  fail "--help"
fi

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
