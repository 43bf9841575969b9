#!/usr/bin/env bash
# ips-replay on real log files: the same input gives a byte-identical output; the regenerated
# estimates meet the lab bound; logs cut short, with garbage, empty or not logs at all are
# reported and never crash the program.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
export PYTHONPATH=$(cd "$(dirname "$0")" && pwd)  # lcm_log.py
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

"$BIN/ips-sim" --scenario lab --seed 1 --duration 60 --out "$WORK/in.lcm" --log-level warn
"$BIN/ips-replay" "$WORK/in.lcm" --out "$WORK/a.lcm" --log-level warn || fail "replay 1"
"$BIN/ips-replay" "$WORK/in.lcm" --out "$WORK/b.lcm" --log-level warn || fail "replay 2"
cmp -s "$WORK/a.lcm" "$WORK/b.lcm" && echo "ok: byte-identical output" || fail "outputs differ"
json=$("$BIN/ips-eval" --json "$WORK/a.lcm")
rmse=$(echo "$json" | tr '{' '\n' | grep '"channel": "POSE_UWB"' | sed -E 's/.*"rmse_h": ([0-9.]+).*/\1/')
awk -v r="$rmse" 'BEGIN { exit !(r != "" && r <= 0.12) }' && echo "ok: replayed POSE_UWB rmse_h $rmse" ||
  fail "replayed POSE_UWB rmse_h '$rmse' (bound 0.12)"
rmse=$(echo "$json" | tr '{' '\n' | grep '"channel": "POSE_TDOA"' | sed -E 's/.*"rmse_h": ([0-9.]+).*/\1/')
awk -v r="$rmse" 'BEGIN { exit !(r != "" && r <= 0.20) }' && echo "ok: replayed POSE_TDOA rmse_h $rmse" ||
  fail "replayed POSE_TDOA rmse_h '$rmse' (bound 0.20)"
n_clock=$(python3 -c "import lcm_log, sys; print(sum(ch == 'CLOCK' for ch, _, _ in lcm_log.events(sys.argv[1])[0]))" "$WORK/a.lcm")
# 60 s: 30 syncs, each giving a clock_t per anchor (4, the master's included).
[ "$n_clock" -ge 110 ] && [ "$n_clock" -le 120 ] && echo "ok: $n_clock CLOCK events" ||
  fail "CLOCK events: $n_clock (expected about 120)"

# Replaying the output again regenerates the estimates instead of doubling them.
"$BIN/ips-replay" "$WORK/a.lcm" --out "$WORK/c.lcm" --log-level warn
n_a=$(grep -ac POSE_UWB "$WORK/a.lcm" || true)
n_c=$(grep -ac POSE_UWB "$WORK/c.lcm" || true)
[ "$n_a" = "$n_c" ] && echo "ok: re-replay keeps one POSE_UWB stream" || fail "POSE_UWB lines $n_a vs $n_c"
n_a=$(grep -ac POSE_TDOA "$WORK/a.lcm" || true)
n_c=$(grep -ac POSE_TDOA "$WORK/c.lcm" || true)
[ "$n_a" = "$n_c" ] && echo "ok: re-replay keeps one POSE_TDOA stream" || fail "POSE_TDOA lines $n_a vs $n_c"

# --tags / --shard: the hosted estimators take one tag's messages; the inputs still pass through.
"$BIN/ips-sim" --scenario lab --seed 1 --duration 10 --tags 3 --out "$WORK/three.lcm" --log-level warn
msg=$("$BIN/ips-replay" "$WORK/three.lcm" --tags T1-2 --out "$WORK/one.lcm" 2>&1) || fail "replay --tags"
echo "$msg" | grep -Eq 'the tags T1-2: [1-9][0-9]* messages of other tags not estimated' &&
  echo "ok: --tags says what it skipped" || fail "--tags summary: $msg"
tags=$(python3 -c "
import lcm_log, lcm_messages, sys
print(' '.join(sorted({lcm_messages.pose(p)['tag_id'] for ch, _, p in lcm_log.events(sys.argv[1])[0] if ch == 'POSE_FUSED'})))" "$WORK/one.lcm")
[ "$tags" = "T1-2" ] && echo "ok: --tags T1-2 fuses only T1-2" || fail "--tags T1-2 fused tags '$tags'"
count_ranges() { python3 -c "import lcm_log, sys; print(sum(ch == 'UWB_RANGE' for ch, _, _ in lcm_log.events(sys.argv[1])[0]))" "$1"; }
n_in=$(count_ranges "$WORK/three.lcm")
n_out=$(count_ranges "$WORK/one.lcm")
[ "$n_in" = "$n_out" ] && echo "ok: every input passed through" || fail "UWB_RANGE lines $n_in in, $n_out out"
"$BIN/ips-replay" "$WORK/three.lcm" --shard 4/3 --out "$WORK/x.lcm" 2>"$WORK/err"
[ $? -eq 2 ] && grep -q 'shard' "$WORK/err" && echo "ok: a bad --shard is refused" ||
  fail "bad --shard: $(cat "$WORK/err")"

# Damaged inputs.
head -c 100000 "$WORK/in.lcm" >"$WORK/cut.lcm"
if "$BIN/ips-replay" "$WORK/cut.lcm" --out "$WORK/d.lcm" 2>"$WORK/err"; then
  grep -q "stopped at byte" "$WORK/err" && echo "ok: cut log reported" || fail "cut log not reported"
else fail "cut log: non-zero exit"; fi
{ head -c 50000 "$WORK/in.lcm"; python3 "$(dirname "$0")/lcm_log.py" garbage 3000; tail -c 50000 "$WORK/in.lcm"; } >"$WORK/garbage.lcm"
"$BIN/ips-replay" "$WORK/garbage.lcm" --out "$WORK/e.lcm" 2>"$WORK/err"; st=$?
[ "$st" -eq 0 ] && grep -q "stopped at byte\|events in" "$WORK/err" && echo "ok: garbage reported (status $st)" ||
  fail "garbage log: status $st: $(cat "$WORK/err")"
# Garbage inserted in the middle of a whole log: replay reads on after it (every input event after
# the garbage is in the output; only the one it landed in may be lost) and says how much it skipped.
size=$(stat -c %s "$WORK/in.lcm")
{ head -c $((size / 2)) "$WORK/in.lcm"; python3 "$(dirname "$0")/lcm_log.py" garbage 3000; tail -c +$((size / 2 + 1)) "$WORK/in.lcm"; } >"$WORK/mid.lcm"
"$BIN/ips-replay" "$WORK/mid.lcm" --out "$WORK/h.lcm" 2>"$WORK/err"; st=$?
# Events per channel, and the last timestamp, of an undamaged log (LCM log format, big-endian).
log_summary() {  # events other than POSE_UWB, and the last timestamp
  python3 - "$1" <<'PY'
import sys, lcm_log
evs, _, _ = lcm_log.events(sys.argv[1])
print(sum(1 for ch, _, _ in evs if ch != 'POSE_UWB'), evs[-1][1] if evs else None)
PY
}
read -r n_in last_in < <(log_summary "$WORK/in.lcm")
read -r n_out last_out < <(log_summary "$WORK/h.lcm")
if [ "$st" -eq 0 ] && grep -Eq "skipped [0-9]+ damaged bytes in 1 places and read on" "$WORK/err" &&
  [ "$last_out" = "$last_in" ] && [ "$n_out" -ge $((n_in - 1)) ]; then
  echo "ok: garbage in the middle skipped, $n_out of $n_in input events replayed; $(grep skipped "$WORK/err")"
else
  fail "garbage in the middle: status $st, $n_out of $n_in input events, last time $last_out vs $last_in: $(cat "$WORK/err")"
fi
: >"$WORK/empty.lcm"
# An empty log holds input for no estimator: said in one line, status 1 (nothing silent).
"$BIN/ips-replay" "$WORK/empty.lcm" --out "$WORK/f.lcm" --log-level warn 2>"$WORK/err"; st=$?
[ "$st" -eq 1 ] && grep -q "the log holds no input for the hosted estimators" "$WORK/err" &&
  [ "$(wc -l <"$WORK/err")" -eq 1 ] && echo "ok: empty log: status 1, $(cat "$WORK/err")" ||
  fail "empty log: status $st: $(cat "$WORK/err")"
echo "not a log" >"$WORK/text.lcm"
"$BIN/ips-replay" "$WORK/text.lcm" --out "$WORK/g.lcm" 2>"$WORK/err"; st=$?
[ "$st" -eq 2 ] && grep -q "is not an LCM log" "$WORK/err" && echo "ok: not a log" || fail "text file: status $st"
"$BIN/ips-replay" "$WORK/in.lcm" --out /nonexistent/dir/x.lcm 2>"$WORK/err"; st=$?
[ "$st" -eq 2 ] && [ "$(wc -l <"$WORK/err")" -eq 1 ] && echo "ok: unwritable output" || fail "unwritable: status $st"

# Nothing silent: a log without SITE gives no estimate; ips-replay says why per estimator, in the
# error line, and exits 1; with --site the same log gives estimates again.
"$BIN/ips-sim" --scenario aoa-hall --seed 1 --duration 10 --out "$WORK/aoa.lcm" --log-level warn
python3 - "$WORK/aoa.lcm" "$WORK/nosite.lcm" <<'PY'
import struct, sys, lcm_log
evs, _, _ = lcm_log.events(sys.argv[1])
with open(sys.argv[2], 'wb') as f:
    for n, (ch, ts, d) in enumerate(e for e in evs if e[0] != 'SITE'):
        c = ch.encode('latin-1')
        f.write(struct.pack('>IqqII', lcm_log.MAGIC, n, ts, len(c), len(d)) + c + d)
PY
"$BIN/ips-replay" "$WORK/nosite.lcm" --only aoa --out "$WORK/ns.lcm" 2>"$WORK/err"; st=$?
if [ "$st" -eq 1 ] &&
  grep -Eq "^ips-replay: error: no hosted estimator gave an estimate: aoa: [0-9]+ BLE_AOA in, 0 estimates out: [0-9]+ no site \(the log has no SITE: give --site FILE\)$" "$WORK/err" &&
  grep -Eq "info ips-replay: aoa: [0-9]+ BLE_AOA in, 0 estimates out: [0-9]+ no site" "$WORK/err"; then
  echo "ok: no site: status 1, $(grep error "$WORK/err")"
else
  fail "no site: status $st: $(cat "$WORK/err")"
fi
# All hosted (the default): the fusion says the same; still one error line at --log-level warn.
"$BIN/ips-replay" "$WORK/nosite.lcm" --out "$WORK/ns.lcm" --log-level warn 2>"$WORK/err"; st=$?
[ "$st" -eq 1 ] && [ "$(wc -l <"$WORK/err")" -eq 1 ] && grep -q "aoa: .* no site" "$WORK/err" &&
  echo "ok: no site, every estimator hosted: status 1" || fail "no site, all hosted: status $st: $(cat "$WORK/err")"
# The lab's ranges without SITE, then with --site: estimates again, status 0, nothing on stderr.
python3 - "$WORK/in.lcm" "$WORK/nosite-lab.lcm" <<'PY'
import struct, sys, lcm_log
evs, _, _ = lcm_log.events(sys.argv[1])
with open(sys.argv[2], 'wb') as f:
    for n, (ch, ts, d) in enumerate(e for e in evs if e[0] != 'SITE'):
        c = ch.encode('latin-1')
        f.write(struct.pack('>IqqII', lcm_log.MAGIC, n, ts, len(c), len(d)) + c + d)
PY
"$BIN/ips-replay" "$WORK/nosite-lab.lcm" --only uwb_twr --out "$WORK/ns.lcm" --log-level warn \
  2>"$WORK/err"; st=$?
[ "$st" -eq 1 ] && grep -q "uwb_twr: [0-9]* UWB_RANGE in, 0 estimates out: [0-9]* no site" "$WORK/err" ||
  fail "lab without SITE: status $st: $(cat "$WORK/err")"
"$BIN/ips-replay" "$WORK/nosite-lab.lcm" --only uwb_twr --site "$ROOT/config/sites/lab.yaml" \
  --out "$WORK/ns.lcm" --log-level warn 2>"$WORK/err" && [ ! -s "$WORK/err" ] &&
  echo "ok: without SITE status 1, with --site status 0" || fail "lab with --site: $(cat "$WORK/err")"

# On a terminal (script(1) gives it a pseudo-terminal) a progress line that ends at 100 %; in a
# pipe, none.
if command -v script >/dev/null; then
  tty_out=$(script -qfec "'$BIN/ips-replay' '$WORK/in.lcm' --out '$WORK/tty.lcm' --log-level warn" /dev/null |
    tr '\r' '\n')
  if echo "$tty_out" | grep -Eq '^ips-replay: \[#{20}\] 100 %  [0-9.]+ k? ?events' &&
    cmp -s "$WORK/tty.lcm" "$WORK/a.lcm"; then
    echo "ok: progress line on a terminal: $(echo "$tty_out" | grep '100 %' | tr -s ' ')"
  else
    fail "no progress line ending at 100 % on a terminal: $tty_out"
  fi
  "$BIN/ips-replay" "$WORK/in.lcm" --out "$WORK/pipe.lcm" --log-level warn 2>"$WORK/err" | cat
  [ ! -s "$WORK/err" ] && echo "ok: no progress line in a pipe" || fail "stderr in a pipe: $(cat "$WORK/err")"
else
  echo "skip: no script(1) for a pseudo-terminal"
fi

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
