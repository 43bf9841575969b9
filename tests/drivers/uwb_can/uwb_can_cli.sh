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
. "$(dirname "$0")/../../integration/cli_check_lib.sh"  # fail, expect_saying; counts failures

# --- SocketCAN: no AF_CAN here, or no such interface -----------------------------------------
if python3 -c 'import socket; socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)' 2>/dev/null; then
  echo "this kernel has AF_CAN: checking the interface messages"
  expect_saying 1 "no network interface 'nosuch0'" "$BIN/ips-uwb-can" --interface nosuch0
  expect_saying 1 "'lo' is not a CAN interface" "$BIN/ips-uwb-can" --interface lo
else
  echo "this kernel has no AF_CAN: checking that message"
  expect_saying 1 "this kernel has no SocketCAN support (AF_CAN)" "$BIN/ips-uwb-can" --interface can0
  expect_saying 1 "--candump-file FILE or --candump-stdin" "$BIN/ips-uwb-can" --interface can0
  expect_saying 1 "(and there is no interface 'nosuch0')" "$BIN/ips-uwb-can" --interface nosuch0
  rc=0; err=$("$BIN/ips-uwb-can" --interface lo 2>&1) || rc=$?
  [ "$rc" -eq 1 ] && [[ "$err" == *"(AF_CAN)"* ]] && [[ "$err" != *"no interface"* ]] ||
    fail "--interface lo (exists, no AF_CAN): $rc $err"
fi

# --- bad command lines: status 2 ---------------------------------------------------------------
expect_saying 2 "give exactly one of" "$BIN/ips-uwb-can"
expect_saying 2 "give exactly one of" "$BIN/ips-uwb-can" --candump-stdin --candump-file x.log
expect_saying 2 "give exactly one of" "$BIN/ips-uwb-can" --interface can0 --candump-stdin
expect_saying 2 "--base-id" "$BIN/ips-uwb-can" --candump-stdin --base-id 0x800
expect_saying 2 "--base-id" "$BIN/ips-uwb-can" --candump-stdin --base-id banana
expect_saying 2 "go past 0x7FF" "$BIN/ips-uwb-can" --candump-stdin --base-id 0x7F0 --anchors 32
expect_saying 2 "at least one anchor" "$BIN/ips-uwb-can" --candump-stdin --anchors 0
expect_saying 2 "'x' is not an anchor number (0..127)" "$BIN/ips-uwb-can" --candump-stdin --anchor-id x=A1
expect_saying 2 "--tag-id 70000=T" "$BIN/ips-uwb-can" --candump-stdin --tag-id 70000=T
expect_saying 2 "is also the default name of anchor 3" "$BIN/ips-uwb-can" --candump-stdin --anchor-id 7=A3
expect_saying 2 "is given to two anchors" "$BIN/ips-uwb-can" --candump-stdin --anchor-id 1=hall --anchor-id 2=hall
expect_saying 2 "--fd goes with" "$BIN/ips-uwb-can" --candump-stdin --fd
expect_saying 2 "--speed goes with" "$BIN/ips-uwb-can" --interface can0 --speed 2
expect_saying 2 "--time-from" "$BIN/ips-uwb-can" --candump-stdin --time-from sometimes
expect_saying 2 "--interface: empty" "$BIN/ips-uwb-can" --interface ""
expect_saying 2 "cannot be written as a candump interface" "$BIN/ips-uwb-can" --to-candump x.lcm --interface 'a#b'
expect_saying 1 "cannot read candump log" "$BIN/ips-uwb-can" --candump-file "$WORK/none.log"

# --- --to-candump on files ------------------------------------------------------------------
"$BIN/ips-sim" --scenario lab --duration 2 --out "$WORK/sim.lcm" --log-level warn
expect_saying 1 "cannot read log" "$BIN/ips-uwb-can" --to-candump "$WORK/none.lcm"
echo "not a log" > "$WORK/text.lcm"
expect_saying 1 "is not an LCM log" "$BIN/ips-uwb-can" --to-candump "$WORK/text.lcm"
expect_saying 1 "anchor id 'A1' has no anchor number" "$BIN/ips-uwb-can" --to-candump "$WORK/sim.lcm" --anchor-prefix X
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
