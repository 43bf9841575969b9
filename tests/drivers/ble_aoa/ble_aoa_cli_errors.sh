#!/usr/bin/env bash
# ips-ble-aoa start-up errors: each is one line "ips-ble-aoa: error: <what>" and status 2, before
# anything is opened; --help is status 0. No LCM traffic: every case fails before the bus is
# used, or (a device that is not a terminal) right after.
set -euo pipefail
BIN=$(cd "$1" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
export LCM_DEFAULT_URL="memq://"
touch "$WORK/plain-file" "$WORK/cap.csv"
D="$WORK/ttyAOA0"

refuse() {  # expected-text args...
  local want=$1 rc=0 err
  shift
  err=$("$BIN/ips-ble-aoa" "$@" 2>&1 >/dev/null) || rc=$?
  [ "$rc" -eq 2 ] || fail "ips-ble-aoa $*: status $rc (expected 2): $err"
  [ "$(echo "$err" | wc -l)" -eq 1 ] || fail "ips-ble-aoa $*: more than one line: $err"
  [[ "$err" == "ips-ble-aoa: error: "* ]] || fail "ips-ble-aoa $*: not an error line: $err"
  echo "$err" | grep -qF -- "$want" || fail "ips-ble-aoa $*: '$err' does not say '$want'"
  echo "ok: $err"
}
refuse "--device (one per anchor) or --capture is required"
refuse "--device $WORK: is a directory" --device "$WORK"
refuse "is a regular file, not a serial device" --device "$WORK/plain-file"
refuse "--device /dev/null: not a terminal (serial) device" --device /dev/null
refuse "--device $D is given twice" --device "$D" --device "$D"
refuse "--device and --capture exclude each other" --device "$D" --capture "$WORK/cap.csv"
refuse "--baud: 12345 is not a speed termios can set" --device "$D" --baud 12345
refuse "--reopen-s" --device "$D" --reopen-s 0
refuse "--angle-range: expected pm90, 0-180 or auto, got '0..180'" --device "$D" --angle-range 0..180
refuse "--legacy-offset-deg" --device "$D" --legacy-offset-deg 1000
refuse "--anchor-name: 'A1' is not HWID=ID" --device "$D" --anchor-name A1
refuse "--anchor-name: '6C1DEBA09862=A 1' is not HWID=ID" --device "$D" --anchor-name "6C1DEBA09862=A 1"
refuse "--anchor-name: 6C1DEBA09862 is named twice" --device "$D" --anchor-name 6C1DEBA09862=A1 \
  --anchor-name 6C1DEBA09862=A2
refuse "--at-command needs --enable-events" --device "$D" --at-command AT+UDFCFG=1,50
refuse "--at-command: 'UDFCFG=1' is not an AT command" --device "$D" --enable-events \
  --at-command UDFCFG=1
refuse "--enable-events goes with --device" --capture "$WORK/cap.csv" --enable-events
refuse "--out goes with --capture" --device "$D" --out "$WORK/x.lcm"
refuse "--speed goes with --capture" --device "$D" --speed 2
refuse "--timezone goes with --capture" --device "$D" --timezone UTC
refuse "--speed excludes --as-fast-as-possible" --capture "$WORK/cap.csv" --speed 2 --as-fast-as-possible
refuse "--out excludes --speed" --capture "$WORK/cap.csv" --out "$WORK/x.lcm" --speed 2
refuse "--timezone: 'Mars/Olympus' is not UTC, +HH:MM or a zone name" --capture "$WORK/cap.csv" \
  --timezone Mars/Olympus
refuse "--timezone: '../etc/passwd'" --capture "$WORK/cap.csv" --timezone ../etc/passwd
refuse "--capture: cannot read '$WORK/missing.csv': No such file or directory" \
  --capture "$WORK/missing.csv"
refuse "--capture: '$WORK' is a directory" --capture "$WORK"
refuse "--channel: unknown kind" --device "$D" --channel BLE=X

out=$("$BIN/ips-ble-aoa" --help) || fail "--help: status $?"
for flag in --device --baud --reopen-s --enable-events --at-command --angle-range --legacy-offset-deg \
  --duplicate-window-s --anchor-name --capture --out --speed --as-fast-as-possible --timezone \
  --lcm-url --channel --log-level; do
  grep -q -- "$flag" <<<"$out" || fail "--help does not list $flag"
done
echo "ok: --help lists every flag"
