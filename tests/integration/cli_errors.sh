#!/usr/bin/env bash
# Bad input on the command line: a malformed site file, an unknown scenario, an LCM URL that
# cannot be opened, a missing log. Each gives exactly one clear error line on stderr and a
# non-zero exit status, never a crash. And every program answers --help with status 0.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"  # fail, expect (WANT_LINES); counts failures

cat >"$WORK/bad-site.yaml" <<'YAML'
name: broken
anchors:
  - {id: A1, position: [0, 0]}
YAML
printf 'name: x\nanchors: [ {id: A1\n' >"$WORK/bad-syntax.yaml"

expect 2 "^ips-uwb-twr: error: .*bad-site.yaml:3: anchors\[0\]\.position: expected a list of 3 numbers" \
  "$BIN/ips-uwb-twr" --lcm-url memq:// --site "$WORK/bad-site.yaml"
expect 2 "^ips-uwb-twr: error: .*bad-syntax.yaml:[0-9]+:[0-9]+: YAML syntax error" \
  "$BIN/ips-uwb-twr" --lcm-url memq:// --site "$WORK/bad-syntax.yaml"
expect 2 "^ips-uwb-twr: error: /nonexistent.yaml: cannot read: No such file or directory" \
  "$BIN/ips-uwb-twr" --lcm-url memq:// --site /nonexistent.yaml
expect 2 "^ips-sim: error: unknown scenario 'atlantis': not a built-in scenario \(.*lab.*\) and not a readable file" \
  "$BIN/ips-sim" --scenario atlantis
expect 2 "^ips-sim: error: .*bad-site.yaml:[0-9]+: .*" \
  "$BIN/ips-sim" --scenario "$WORK/bad-site.yaml" --out "$WORK/x.lcm"
expect 1 "^ips-uwb-twr: error: cannot open LCM URL 'bogus://nowhere'" \
  "$BIN/ips-uwb-twr" --lcm-url bogus://nowhere --site "$ROOT/config/sites/lab.yaml"
expect 1 "^ips-sim: error: cannot open LCM URL 'udpm://300.1.2.3:7667'" \
  "$BIN/ips-sim" --scenario lab --lcm-url udpm://300.1.2.3:7667
expect 1 "^ips-bus-check: error: cannot open LCM URL 'udpm://nohost'" \
  "$BIN/ips-bus-check" --lcm-url udpm://nohost
expect 2 "^ips-eval: error: cannot read log '/nonexistent.lcm'" "$BIN/ips-eval" /nonexistent.lcm
expect 2 "^ips-sim: error: .*--seed" "$BIN/ips-sim" --scenario lab --seed minus-one
expect 2 "^ips-uwb-twr: error: The following argument was not expected: --frobnicate" \
  "$BIN/ips-uwb-twr" --frobnicate

# Logs that are not logs, or are cut short.
echo "just text, not a log" >"$WORK/text.lcm"
expect 2 "^ips-eval: error: '.*text.lcm' is not an LCM log \(no readable event\)" "$BIN/ips-eval" "$WORK/text.lcm"
expect 2 "^ips-eval: error: cannot read log '.*': not a regular file" "$BIN/ips-eval" "$WORK"
"$BIN/ips-sim" --scenario lab --duration 5 --out "$WORK/full.lcm" --log-level warn
head -c 20000 "$WORK/full.lcm" >"$WORK/cut.lcm"
expect 0 "^ips-eval: warning: .*cut.lcm: read [0-9]+ events, then stopped at byte [0-9]+ of 20000" \
  "$BIN/ips-eval" "$WORK/cut.lcm"
# Garbage in the middle: skipped, reported, and everything after it scored.
size=$(stat -c %s "$WORK/full.lcm")
{ head -c $((size / 2)) "$WORK/full.lcm"; python3 "$(dirname "$0")/lcm_log.py" garbage 3000
  tail -c +$((size / 2 + 1)) "$WORK/full.lcm"; } >"$WORK/mid.lcm"
expect 0 "^ips-eval: warning: .*mid.lcm: skipped [0-9]+ damaged bytes in 1 places and read on after" \
  "$BIN/ips-eval" "$WORK/mid.lcm"
mid_truth=$(sed -nE 's/.* ([0-9]+) truth samples.*/\1/p' "$WORK/out")
full_truth=$("$BIN/ips-eval" "$WORK/full.lcm" 2>/dev/null | sed -nE 's/.* ([0-9]+) truth samples.*/\1/p')
if [ -n "$mid_truth" ] && [ "$mid_truth" -ge $((full_truth - 1)) ]; then
  echo "ok: ips-eval read on after garbage: $mid_truth of $full_truth truth samples"
else
  echo "FAIL: ips-eval after garbage: '$mid_truth' of '$full_truth' truth samples"
  failures=$((failures + 1))
fi
expect 2 "^ips-eval: error: --static-point: At least 2 required" "$BIN/ips-eval" "$WORK/full.lcm" --static-point 5
expect 2 "^ips-sim: error: --out excludes --speed" \
  "$BIN/ips-sim" --scenario lab --out "$WORK/y.lcm" --speed 2
expect 2 "^ips-uwb-twr: error: --channel: unknown kind 'POSE_UBW'" \
  "$BIN/ips-uwb-twr" --channel POSE_UBW=X
expect 2 "^ips-uwb-tdoa: error: .*nowhere.yaml" "$BIN/ips-uwb-tdoa" --site "$WORK/nowhere.yaml"

# An estimator of one anchor kind given a site without any says so at start (issue 23): a warning
# naming the site, what it has and the program, before any input; it keeps running (a site with
# them may come). Waited for with a generous bound, then stopped with SIGINT.
printf 'name: uwb-only\nanchors:\n  - {id: A1, position: [0, 0, 2]}\n  - {id: A2, position: [5, 0, 2]}\n' \
  >"$WORK/uwb-only.yaml"
for pk in ips-aoa:ble_aoa ips-uwb-tdoa:uwb_tdoa; do
  prog=${pk%%:*} kind=${pk#*:}
  "$BIN/$prog" --lcm-url memq:// --site "$WORK/uwb-only.yaml" >"$WORK/out" 2>"$WORK/err" &
  pid=$!
  want="$prog: site 'uwb-only' \(.*uwb-only.yaml\) has no enabled $kind anchor \(it has 2 uwb\): $prog estimates nothing until a site with them arrives"
  for _ in $(seq 600); do grep -Eq "$want" "$WORK/err" && break; kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  kill -INT "$pid" 2>/dev/null; wait "$pid"; st=$?
  if grep -Eq "$want" "$WORK/err" && [ "$st" -eq 0 ]; then
    echo "ok: $prog says its site has no $kind anchor"
  else
    echo "FAIL: $prog on a site without $kind anchors (status $st): $(head -3 "$WORK/err")"
    failures=$((failures + 1))
  fi
done

for prog in ips-sim ips-uwb-twr ips-uwb-tdoa ips-uwb-survey ips-eval ips-bus-check; do
  if "$BIN/$prog" --help >"$WORK/out" 2>"$WORK/err" && grep -q -- "--log-level" "$WORK/out" &&
    [ ! -s "$WORK/err" ]; then
    echo "ok: $prog --help"
  else
    echo "FAIL: $prog --help"
    failures=$((failures + 1))
  fi
done

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
