#!/usr/bin/env bash
# ips-uwb-tdoa-anchors' command line on bad input: one line "ips-uwb-tdoa-anchors: error: <what>"
# each time, status 2 for a bad command line, 1 for what fails at run time; --help; --to-records
# and --file on real files (LCM in memory, memq://, so no network is needed).
set -uo pipefail
BIN=$(cd "$1" && pwd)
P=ips-uwb-tdoa-anchors
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$(dirname "$0")/../../integration/cli_check_lib.sh"  # fail, expect_saying; counts failures

out=$("$BIN/$P" --help) || fail "--help: status $?"
for flag in --tcp --udp --file --to-records --id --rate --rx-power --lcm-url --channel --log-level; do
  [[ "$out" == *"$flag"* ]] || fail "--help does not mention $flag"
done

expect_saying 2 "give exactly one of --tcp, --udp, --file, --to-records" "$BIN/$P"
expect_saying 2 "give exactly one of" "$BIN/$P" --tcp 127.0.0.1:5000 --udp 5000
expect_saying 2 "--rate goes with --file" "$BIN/$P" --tcp 127.0.0.1:5000 --rate 10
expect_saying 2 "--reconnect-max-s goes with --tcp" "$BIN/$P" --udp 5000 --reconnect-max-s 2
expect_saying 2 "expected HOST:PORT" "$BIN/$P" --tcp 127.0.0.1
expect_saying 2 "port '70000x' is not a number" "$BIN/$P" --tcp host:70000x
expect_saying 2 "port 70000 is not in 1..65535" "$BIN/$P" --tcp host:70000
expect_saying 2 "write an IPv6 address as [ADDR]:PORT" "$BIN/$P" --tcp ::1:5000
expect_saying 2 "'localhost' is not an IPv4 address" "$BIN/$P" --udp localhost:5000
expect_saying 2 "port 0 is not in 1..65535" "$BIN/$P" --udp 0
expect_saying 2 "--id 0006: expected HEX=NAME" "$BIN/$P" --udp 5000 --id 0006
expect_saying 2 "'06' is not a 4-hex-digit wire id" "$BIN/$P" --udp 5000 --id 06=A6
expect_saying 2 "is named twice" "$BIN/$P" --udp 5000 --id 0006=A6 --id 0006=B6
expect_saying 2 "--rate" "$BIN/$P" --file x --rate -1
expect_saying 2 "--channel" "$BIN/$P" --udp 5000 --channel NOPE=X
expect_saying 2 "--rx-power" "$BIN/$P" --udp 5000 --rx-power dw1000
expect_saying 2 "--rx-power does not go with --to-records" "$BIN/$P" --to-records x.lcm --rx-power dw1000-prf64
expect_saying 1 "cannot read '$WORK/missing.txt'" "$BIN/$P" --file "$WORK/missing.txt"
expect_saying 1 "cannot read log '$WORK/missing.lcm'" "$BIN/$P" --to-records "$WORK/missing.lcm"
head -c 2000 /dev/urandom > "$WORK/noise.bin"
expect_saying 1 "is not an LCM log" "$BIN/$P" --to-records "$WORK/noise.bin"
printf 'hello\nworld\n' > "$WORK/text.txt"
expect_saying 1 "holds no anchor report record (first: record does not start with '|'" "$BIN/$P" \
  --lcm-url memq:// --log-level off --file "$WORK/text.txt"
python3 -c 'import socket,time,sys; s=socket.socket(socket.AF_INET,socket.SOCK_DGRAM); s.bind(("127.0.0.1",0)); print(s.getsockname()[1],flush=True); time.sleep(120)' > "$WORK/port" 2>/dev/null &
holder=$!
for _ in $(seq 1200); do [ -s "$WORK/port" ] && break; sleep 0.05; done
expect_saying 1 "cannot bind UDP 127.0.0.1:$(cat "$WORK/port")" "$BIN/$P" --lcm-url memq:// \
  --udp "$(cat "$WORK/port")"
kill $holder 2>/dev/null

# A file of good and bad records: the good ones are read, the bad ones counted; status 0.
printf '%s\n' '|0001|E|0001|aa|034|136|3b|3e|87|fe|b5|57.63|' 'bad' \
  '|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|218|2301|12|3084|2470|218|237|744.3593|' \
  > "$WORK/mixed.txt"
err=$("$BIN/$P" --lcm-url memq:// --file "$WORK/mixed.txt" 2>&1) || fail "--file mixed: $?: $err"
[[ "$err" == *"3 records, 2 published, 1 bad"* ]] || fail "--file mixed summary: $err"

# --to-records of a log without UWB_RX: a warning, no records, status 0.
"$BIN/ips-sim" --scenario aoa-hall --duration 1 --out "$WORK/aoa.lcm" --log-level warn
rc=0; err=$("$BIN/$P" --to-records "$WORK/aoa.lcm" 2>&1 > "$WORK/none.txt") || rc=$?
[ "$rc" -eq 0 ] && [ ! -s "$WORK/none.txt" ] && [[ "$err" == *"no UWB_RX message"* ]] ||
  fail "--to-records without UWB_RX: $rc: $err"
# --id names are used by --to-records: A4 given 00a4, so the others get 0001.. and T1 1001.
"$BIN/ips-sim" --scenario tdoa-hall --duration 0.5 --out "$WORK/t.lcm" --log-level warn
"$BIN/$P" --to-records "$WORK/t.lcm" --id 00a4=A4 > "$WORK/t.txt" 2> "$WORK/t.err" ||
  fail "--to-records --id: $(cat "$WORK/t.err")"
grep -q '^|00a4|E|00a4|aa|' "$WORK/t.txt" || fail "--id 00a4=A4 not used: $(head -3 "$WORK/t.txt")"
grep -q -- '--id 0001=A1 --id 0002=A2 --id 0003=A3 --id 0004=A5 --id 0005=A6 --id 1001=T1' \
  "$WORK/t.err" || fail "--to-records assigned ids: $(cat "$WORK/t.err")"

[ "$failures" -eq 0 ] || { echo "$failures failure(s)"; exit 1; }
echo PASS
