#!/usr/bin/env bash
# ips-uwb-can's command line on bad input and missing CAN support: one line
# "ips-uwb-can: error: <what>" each time, status 2 for a bad command line, 1 for what fails at
# run time; and --to-candump on real files. Needs no network and no CAN support: where the kernel
# has no AF_CAN (socket() fails with EAFNOSUPPORT) that is the message checked, elsewhere the
# messages for an interface that does not exist or is not CAN.
set -uo pipefail
BIN=$(cd "$1" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

expect() {  # status expected-text args...
  local want_rc=$1 want=$2 rc=0 err
  shift 2
  err=$("$BIN/ips-uwb-can" "$@" 2>&1 >/dev/null) || rc=$?
  if [ "$rc" -ne "$want_rc" ]; then fail "ips-uwb-can $*: status $rc (expected $want_rc): $err"; return; fi
  if [ "$(printf '%s\n' "$err" | wc -l)" -ne 1 ]; then fail "ips-uwb-can $*: not one line: $err"; return; fi
  case "$err" in
    "ips-uwb-can: error: "*"$want"*) echo "ok: ips-uwb-can $* -> $rc: $err" ;;
    *) fail "ips-uwb-can $*: '$err' does not say '$want'" ;;
  esac
}

# --- SocketCAN: no AF_CAN here, or no such interface -----------------------------------------
if python3 -c 'import socket; socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)' 2>/dev/null; then
  echo "this kernel has AF_CAN: checking the interface messages"
  expect 1 "no network interface 'nosuch0'" --interface nosuch0
  expect 1 "'lo' is not a CAN interface" --interface lo
else
  echo "this kernel has no AF_CAN: checking that message"
  expect 1 "this kernel has no SocketCAN support (AF_CAN)" --interface can0
  expect 1 "--candump-file FILE or --candump-stdin" --interface can0
  expect 1 "(and there is no interface 'nosuch0')" --interface nosuch0
  rc=0; err=$("$BIN/ips-uwb-can" --interface lo 2>&1) || rc=$?
  [ "$rc" -eq 1 ] && [[ "$err" == *"(AF_CAN)"* ]] && [[ "$err" != *"no interface"* ]] ||
    fail "--interface lo (exists, no AF_CAN): $rc $err"
fi

# --- bad command lines: status 2 ---------------------------------------------------------------
expect 2 "give exactly one of" 
expect 2 "give exactly one of" --candump-stdin --candump-file x.log
expect 2 "give exactly one of" --interface can0 --candump-stdin
expect 2 "--base-id" --candump-stdin --base-id 0x800
expect 2 "--base-id" --candump-stdin --base-id banana
expect 2 "go past 0x7FF" --candump-stdin --base-id 0x7F0 --anchors 32
expect 2 "at least one anchor" --candump-stdin --anchors 0
expect 2 "'x' is not an anchor number (0..127)" --candump-stdin --anchor-id x=A1
expect 2 "--tag-id 70000=T" --candump-stdin --tag-id 70000=T
expect 2 "is also the default name of anchor 3" --candump-stdin --anchor-id 7=A3
expect 2 "is given to two anchors" --candump-stdin --anchor-id 1=hall --anchor-id 2=hall
expect 2 "--fd goes with" --candump-stdin --fd
expect 2 "--speed goes with" --interface can0 --speed 2
expect 2 "--time-from" --candump-stdin --time-from sometimes
expect 2 "--interface: empty" --interface ""
expect 2 "cannot be written as a candump interface" --to-candump x.lcm --interface 'a#b'
expect 1 "cannot read candump log" --candump-file "$WORK/none.log"

# --- --to-candump on files ------------------------------------------------------------------
"$BIN/ips-sim" --scenario lab --duration 2 --out "$WORK/sim.lcm" --log-level warn
expect 1 "cannot read log" --to-candump "$WORK/none.lcm"
echo "not a log" > "$WORK/text.lcm"
expect 1 "is not an LCM log" --to-candump "$WORK/text.lcm"
expect 1 "anchor id 'A1' has no anchor number" --to-candump "$WORK/sim.lcm" --anchor-prefix X
"$BIN/ips-uwb-can" --to-candump "$WORK/sim.lcm" --log-level warn > "$WORK/classic.log" ||
  fail "--to-candump exited with $?"
"$BIN/ips-uwb-can" --to-candump "$WORK/sim.lcm" --fd --interface vcan0 --base-id 0x100 \
  --anchor-id 2=A1 --anchor-id 1=A2 --log-level warn > "$WORK/fd.log" || fail "--to-candump --fd exited with $?"
python3 - "$WORK/classic.log" "$WORK/fd.log" <<'PY' || fail "--to-candump output"
import re, sys
classic = open(sys.argv[1]).read().splitlines()
fd = open(sys.argv[2]).read().splitlines()
assert len(classic) == len(fd) >= 70, (len(classic), len(fd))
pat_c = re.compile(r'^\((\d{10}\.\d{6})\) can0 (30[1-4])#([0-9A-F]{16})$')
pat_f = re.compile(r'^\((\d{10}\.\d{6})\) vcan0 (10[1-4])##0([0-9A-F]{16})$')
swap = {'301': '102', '302': '101', '303': '103', '304': '104'}
for c, f in zip(classic, fd):
    mc, mf = pat_c.match(c), pat_f.match(f)
    assert mc and mf, (c, f)
    assert mc.group(1) == mf.group(1) and mc.group(3) == mf.group(3), (c, f)
    assert swap[mc.group(2)] == mf.group(2), (c, f)   # --anchor-id 2=A1 1=A2 and --base-id 0x100
    payload = bytes.fromhex(mc.group(3))
    assert payload[0:2] == b'\x01\x00', c              # tag T1, u16 little endian
    assert 500 < int.from_bytes(payload[2:6], 'little') < 15000, c   # mm inside a 10 x 8 m lab
    assert payload[6] == 255, c                        # the simulator gives no quality
print(f'ok: --to-candump: {len(classic)} classic lines, the same as CAN FD with renamed anchors')
PY

if [ "$failures" -ne 0 ]; then echo "$failures failure(s)"; exit 1; fi
echo PASS
