#!/usr/bin/env bash
# ips-pdr calibrate on a simulated walk of known length (walk-square, 200 m): with the default
# modified Weinberg model (step_k 1, which the simulated walker's steps follow) the 277 steps sum
# to 199.30 m and the fit gives step_k = (200 + 277 x 0.828) / (199.30 + 277 x 0.828) = 1.0016;
# from a site with a wrong step_k of 1.10 it finds the same 1.0016.
# Then ips-replay --only pdr regenerates STEP and POSE_PDR from the log. Bad command lines: one
# line, status 2. No network needed.
set -euo pipefail
BIN=$(cd "$1" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$BIN/ips-sim" --scenario walk-square --seed 1 --out "$WORK/walk.lcm" --log-level warn

out=$("$BIN/ips-pdr" calibrate --log "$WORK/walk.lcm" --distance 200)
echo "$out"
echo "$out" | grep -q "^ips-pdr: 278 steps of P1, 199.50 m with step_k = 1.0000 (-0.25 % of 200.00 m)$" ||
  fail "calibrate: unexpected summary"
echo "$out" | grep -q "^site file, estimators.pdr: {step_model: modified_weinberg, step_k: 1.0012}$" ||
  fail "calibrate: unexpected step_k"

cat >"$WORK/site.yaml" <<'YAML'
name: walk-square
anchors: []
tags:
  - {id: P1, height_m: 1.1, start_position: [0, 0], start_heading_deg: 0}
estimators:
  pdr: {step_k: 1.10}
YAML
out=$("$BIN/ips-pdr" calibrate --log "$WORK/walk.lcm" --distance 200 --site "$WORK/site.yaml")
echo "$out"
echo "$out" | grep -q "step_k: 1.0013}$" || fail "calibrate with step_k 1.10: unexpected result"

# Replay regenerates the PDR output: as many STEPs as the calibration counted.
"$BIN/ips-replay" "$WORK/walk.lcm" --only pdr --out "$WORK/replayed.lcm" 2>/dev/null
"$BIN/ips-export" "$WORK/replayed.lcm" --out "$WORK/csv" --channels 'STEP|POSE_PDR' >/dev/null
steps=$(($(wc -l <"$WORK/csv/STEP.csv") - 1))
poses=$(($(wc -l <"$WORK/csv/POSE_PDR.csv") - 1))
[ "$steps" -eq 278 ] && [ "$poses" -eq 278 ] || fail "replay: $steps STEP, $poses POSE_PDR (expected 278)"

expect_error() {  # status 2, one line, containing $1; the rest is the command line
  local want=$1 err rc
  shift
  set +e
  err=$("$@" 2>&1 >/dev/null)
  rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "$*: status $rc (expected 2): $err"
  [ "$(printf '%s\n' "$err" | wc -l)" -eq 1 ] || fail "$*: more than one line: $err"
  printf '%s\n' "$err" | grep -qF -- "$want" || fail "$*: expected '$want', got: $err"
}
expect_error "--distance: expected the walked distance" \
  "$BIN/ips-pdr" calibrate --log "$WORK/walk.lcm" --distance -3
expect_error "cannot read log" "$BIN/ips-pdr" calibrate --log "$WORK/missing.lcm" --distance 10
expect_error "--log is required" "$BIN/ips-pdr" calibrate --distance 10
printf 'estimators:\n  pdr: {detector: fft}\nname: x\nanchors: []\n' >"$WORK/bad.yaml"
expect_error "expected peak or zero_crossing" "$BIN/ips-pdr" --site "$WORK/bad.yaml"
"$BIN/ips-pdr" --help | grep -q "calibrate" || fail "--help does not mention calibrate"
echo PASS
