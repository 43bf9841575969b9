#!/usr/bin/env bash
# Pairwise TDoA end to end through the programs (no network): ips-sim --scenario loco-tdoa (8
# anchors, TDoA2 pairs on UWB_TDOA, anchor L3 1 m short) -> ips-replay (ips-uwb-tdoa's core) ->
# ips-eval: POSE_TDOA within 0.15 m RMSE; the replay's account names UWB_TDOA, counts the gated
# pairs, and its consistency line points at L3's two pairs.
set -uo pipefail
BIN=$(cd "$1" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}
ok() { echo "ok: $*"; }

timeout 120 "$BIN/ips-sim" --scenario loco-tdoa --out "$WORK/sim.lcm" 2>"$WORK/sim.err" ||
  { fail "ips-sim: $(tail -3 "$WORK/sim.err")"; exit 1; }
timeout 120 "$BIN/ips-replay" "$WORK/sim.lcm" --only uwb_tdoa --out "$WORK/out.lcm" 2>"$WORK/replay.err" ||
  { fail "ips-replay: $(tail -3 "$WORK/replay.err")"; exit 1; }
grep -q "uwb_tdoa: 6000 UWB_TDOA in, 599 estimates out; dropped [0-9]*: 1[45][0-9][0-9] gated" "$WORK/replay.err" &&
  ok "replay: 6000 pairs in, 599 poses, a quarter of the pairs (L3's) gated" ||
  fail "replay account: $(grep 'uwb_tdoa:' "$WORK/replay.err" | head -2)"
grep -q "TDOA_PAIR L2>L3: 748 in, 100% gated" "$WORK/replay.err" &&
  grep -q "TDOA_PAIR L3>L4: 748 in, 100% gated" "$WORK/replay.err" &&
  ok "consistency: L3's pairs 100% gated" || fail "consistency: $(grep consistency "$WORK/replay.err")"
timeout 60 "$BIN/ips-eval" "$WORK/out.lcm" >"$WORK/eval.out" 2>&1 || fail "ips-eval: $(cat "$WORK/eval.out")"
rmse=$(awk '$1 == "POSE_TDOA" && $2 == "T1" { print $5 }' "$WORK/eval.out")
awk -v r="$rmse" 'BEGIN { exit !(r != "" && r <= 0.15) }' && ok "POSE_TDOA rmse_h $rmse m <= 0.15" ||
  fail "POSE_TDOA rmse_h '$rmse': $(cat "$WORK/eval.out")"

[ "$failures" -eq 0 ] && echo "all passed" || echo "$failures failed"
exit $((failures > 0))
