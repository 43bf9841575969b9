#!/usr/bin/env bash
# ips-uwb-serial start-up errors: each is one line "ips-uwb-serial: error: <what>" and status 2,
# before anything is opened; --help is status 0. No LCM traffic: every case fails before the bus
# is used, or (a device that is not a terminal) right after.
set -euo pipefail
BIN=$(cd "$1" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
export LCM_DEFAULT_URL="memq://"
touch "$WORK/plain-file"

refuse() {  # expected-text args...
  local want=$1 rc=0 err
  shift
  err=$("$BIN/ips-uwb-serial" "$@" 2>&1 >/dev/null) || rc=$?
  [ "$rc" -eq 2 ] || fail "ips-uwb-serial $*: status $rc (expected 2): $err"
  [ "$(echo "$err" | wc -l)" -eq 1 ] || fail "ips-uwb-serial $*: more than one line: $err"
  [[ "$err" == "ips-uwb-serial: error: "* ]] || fail "ips-uwb-serial $*: not an error line: $err"
  echo "$err" | grep -qF -- "$want" || fail "ips-uwb-serial $*: '$err' does not say '$want'"
  echo "ok: $err"
}
refuse "--device is required"
refuse "--device $WORK: is a directory" --device "$WORK" --tag 1A2B
refuse "is a regular file, not a serial device" --device "$WORK/plain-file" --tag 1A2B
refuse "--device /dev/null: not a terminal (serial) device" --device /dev/null --tag 1A2B
refuse "--tag ID is required for PANS lec lines" --device "$WORK/ttyUWB"
refuse "--tag ID is required" --device "$WORK/ttyUWB" --format auto --pans-shell
refuse "--tag: 'a b' is not 1 to 32" --device "$WORK/ttyUWB" --tag "a b"
refuse "--format: expected pans, line or auto, got 'nmea'" --device "$WORK/ttyUWB" --format nmea
refuse "--baud: 12345 is not a speed termios can set" --device "$WORK/ttyUWB" --format line \
  --baud 12345
refuse "--pans-shell needs --format pans or auto" --device "$WORK/ttyUWB" --format line --pans-shell
refuse "--reopen-s" --device "$WORK/ttyUWB" --format line --reopen-s 0
refuse "--channel: unknown kind" --device "$WORK/ttyUWB" --format line --channel UWB=X

out=$("$BIN/ips-uwb-serial" --help) || fail "--help: status $?"
for flag in --device --baud --format --tag --pans-shell --reopen-s --lcm-url --channel --log-level; do
  grep -q -- "$flag" <<<"$out" || fail "--help does not list $flag"
done
echo "ok: --help lists every flag"
