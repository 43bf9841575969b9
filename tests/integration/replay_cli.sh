#!/usr/bin/env bash
# ips-replay on real log files: the same input gives a byte-identical output; the regenerated
# estimates meet the lab bound; logs cut short, with garbage, empty or not logs at all are
# reported and never crash the program.
set -uo pipefail
BIN=$(cd "$1" && pwd)
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
awk -v r="$rmse" 'BEGIN { exit !(r != "" && r <= 0.15) }' && echo "ok: replayed POSE_UWB rmse_h $rmse" ||
  fail "replayed POSE_UWB rmse_h '$rmse' (bound 0.15)"

# Replaying the output again regenerates POSE_UWB instead of doubling it.
"$BIN/ips-replay" "$WORK/a.lcm" --out "$WORK/c.lcm" --log-level warn
n_a=$(grep -ac POSE_UWB "$WORK/a.lcm" || true)
n_c=$(grep -ac POSE_UWB "$WORK/c.lcm" || true)
[ "$n_a" = "$n_c" ] && echo "ok: re-replay keeps one POSE_UWB stream" || fail "POSE_UWB lines $n_a vs $n_c"

# Damaged inputs.
head -c 100000 "$WORK/in.lcm" >"$WORK/cut.lcm"
if "$BIN/ips-replay" "$WORK/cut.lcm" --out "$WORK/d.lcm" 2>"$WORK/err"; then
  grep -q "stopped at byte" "$WORK/err" && echo "ok: cut log reported" || fail "cut log not reported"
else fail "cut log: non-zero exit"; fi
{ head -c 50000 "$WORK/in.lcm"; head -c 3000 /dev/urandom; tail -c 50000 "$WORK/in.lcm"; } >"$WORK/garbage.lcm"
"$BIN/ips-replay" "$WORK/garbage.lcm" --out "$WORK/e.lcm" 2>"$WORK/err"; st=$?
[ "$st" -eq 0 ] && grep -q "stopped at byte\|events in" "$WORK/err" && echo "ok: garbage reported (status $st)" ||
  fail "garbage log: status $st: $(cat "$WORK/err")"
: >"$WORK/empty.lcm"
"$BIN/ips-replay" "$WORK/empty.lcm" --out "$WORK/f.lcm" --log-level warn && echo "ok: empty log" || fail "empty log"
echo "not a log" >"$WORK/text.lcm"
"$BIN/ips-replay" "$WORK/text.lcm" --out "$WORK/g.lcm" 2>"$WORK/err"; st=$?
[ "$st" -eq 2 ] && grep -q "is not an LCM log" "$WORK/err" && echo "ok: not a log" || fail "text file: status $st"
"$BIN/ips-replay" "$WORK/in.lcm" --out /nonexistent/dir/x.lcm 2>"$WORK/err"; st=$?
[ "$st" -eq 2 ] && [ "$(wc -l <"$WORK/err")" -eq 1 ] && echo "ok: unwritable output" || fail "unwritable: status $st"

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
