#!/usr/bin/env bash
# ips-ble-aoa --capture with files of decoded +UUDF fields (issue 21), hand-made in the layouts of
# the public BLE AoA datasets (Byongho96/ble-localization), not copied from them: two anchors'
# files merged in time order with a header, without one, with ISO-8601 times, the older layout
# with numeric ids and two RSSIs, a whole +UUDF line per row, --anchor-name/--tag-name; exact
# messages in the LCM log. A wrongly separated file and garbage give status 1 and one line with
# the exact hint; usage errors status 2.
#   ble_aoa_capture_cli.sh BIN_DIR
set -euo pipefail
bin=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
source "$here/cli_test_lib.sh"
prog=$bin/ips-ble-aoa
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"

# The BLE_AOA messages of an LCM log, one line each: log time, utime, source, anchor, tag,
# azimuth, elevation, RSSI, channel, seq (decoded independently, lcmtypes/ble_aoa_t.lcm order).
dump() {
  PYTHONPATH=$here python3 - "$1" <<'PY'
import sys, lcm_log
from lcm_messages import _Reader
evs, read, size = lcm_log.events(sys.argv[1])
assert read == size, (read, size)
for ch, ts, data in evs:
    r = _Reader(data)
    m = (r.take('q'), r.string(), r.string(), r.string(), r.take('f'), r.take('f'), r.take('f'),
         r.take('h'), r.take('q'), r.take('i'), r.string())
    assert ch == 'BLE_AOA' and ts == m[0], (ch, ts, m)
    print(m[0], m[1], m[2], m[3], '%g' % m[4], '%g' % m[5], '%g' % m[6], m[7], m[9])
PY
}
# expect_import_error TEXT CMD...: status 1 and exactly one line "ips-ble-aoa: error: TEXT".
expect_import_error() {
  local text=$1 rc
  shift
  set +e
  err=$("$@" 2>&1 >/dev/null)
  rc=$?
  set -e
  [ "$rc" -eq 1 ] || fail "$*: status $rc (expected 1): $err"
  [ "$err" = "ips-ble-aoa: error: $text" ] ||
    fail "$*: expected 'ips-ble-aoa: error: $text', got: $err"
  echo "ok: $err"
}
check_dump() {  # check_dump LOG EXPECTED-FILE WHAT
  dump "$1" >got.txt
  diff -u "$2" got.txt || fail "$3: the messages differ"
  echo "ok: $3: $(wc -l <got.txt) messages exactly"
}

# --- two anchors, a header each, interleaved in time ------------------------------------------
cat >a1.csv <<'EOF2'
Timestamp,Tag,RSSI,Azimuth,Elevation,Channel,Anchor,Sequence
1742248940700,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,100
1742248940720,6C1DEBA3FFAC,-52,-6,-21,27,6C1DEBA09949,101
1742248940740,6C1DEBA3FFAC,-53,-7,-19,3,6C1DEBA09949,102
EOF2
cat >a2.csv <<'EOF2'
Timestamp,Tag,RSSI,Azimuth,Elevation,Channel,Anchor,Sequence
1742248940710,6C1DEBA3FFAC,-61,31,2,20,CCF9579B236F,500
1742248940730,6C1DEBA3FFAC,-60,30,3,27,CCF9579B236F,501
EOF2
cat >want.txt <<'EOF2'
1742248940700000 ips-ble-aoa:a1.csv A1 6C1DEBA3FFAC -5 -20 -57 20 100
1742248940710000 ips-ble-aoa:a2.csv CCF9579B236F 6C1DEBA3FFAC 31 2 -61 20 500
1742248940720000 ips-ble-aoa:a1.csv A1 6C1DEBA3FFAC -6 -21 -52 27 101
1742248940730000 ips-ble-aoa:a2.csv CCF9579B236F 6C1DEBA3FFAC 30 3 -60 27 501
1742248940740000 ips-ble-aoa:a1.csv A1 6C1DEBA3FFAC -7 -19 -53 3 102
EOF2
"$prog" --capture a1.csv a2.csv --anchor-name 6C1DEBA09949=A1 --out two.lcm 2>two.err ||
  fail "two anchors: status $?: $(cat two.err)"
check_dump two.lcm want.txt "two anchors with a header, merged in time order"
grep -qF "a1.csv: 3 rows (columns t,tag,rssi,azimuth,elevation,channel,anchor,seq, time in ms), 3 events from 2025-03-17T22:02:20Z to 2025-03-17T22:02:20Z, 0 duplicates dropped, 0 dropped (angle range unknown), 0 rows rejected" two.err ||
  fail "the per-file summary: $(cat two.err)"
grep -qF "5 events from 2 files written to two.lcm" two.err || fail "the total: $(cat two.err)"

# --- the same without headers, and A2 named too; the tag named ----------------------------------
tail -n +2 a1.csv >b1.csv
tail -n +2 a2.csv >b2.csv
"$prog" --capture b2.csv b1.csv --anchor-name 6C1DEBA09949=A1 --anchor-name CCF9579B236F=A2 \
  --tag-name 6C1DEBA3FFAC=T1 --out nohdr.lcm 2>nohdr.err || fail "no header: $(cat nohdr.err)"
sed -e 's/ips-ble-aoa:a/ips-ble-aoa:b/; s/CCF9579B236F/A2/; s/6C1DEBA3FFAC/T1/' want.txt >want_nohdr.txt
check_dump nohdr.lcm want_nohdr.txt "without headers, given in the other order, all named"

# --- ISO-8601 times (UTC, or with an offset), semicolons detected --------------------------------
cat >iso.csv <<'EOF2'
time;anchor;tag;azimuth;elevation;rssi
2025-03-17T22:02:20.700;A1;T1;10;5;-60
2025-03-18T07:02:20.750+09:00;A1;T1;11;4;-61
EOF2
cat >want_iso.txt <<'EOF2'
1742248940700000 ips-ble-aoa:iso.csv A1 T1 10 5 -60 0 -1
1742248940750000 ips-ble-aoa:iso.csv A1 T1 11 4 -61 0 -1
EOF2
"$prog" --capture iso.csv --out iso.lcm 2>iso.err || fail "ISO times: $(cat iso.err)"
check_dump iso.lcm want_iso.txt "ISO-8601 times, columns by name in another order"

# --- the older layout: numeric ids, two RSSIs, one file for all anchors, no header ---------------
cat >old.csv <<'EOF2'
1670598712042,8401,-70,-32,-12,-75,37,6502
1670598712042,8401,-82,14,8,-72,37,6503
1670598712045,8401,-68,-24,34,-66,39,6501
EOF2
cat >want_old.txt <<'EOF2'
1670598712042000 ips-ble-aoa:old.csv A2 T1 -32 -12 -70 37 -1
1670598712042000 ips-ble-aoa:old.csv 6503 T1 14 8 -82 37 -1
1670598712045000 ips-ble-aoa:old.csv 6501 T1 -24 34 -68 39 -1
EOF2
"$prog" --capture old.csv --anchor-name 6502=A2 --tag-name 8401=T1 --out old.lcm 2>old.err ||
  fail "older layout: $(cat old.err)"
check_dump old.lcm want_old.txt "older layout with numeric ids (detected)"
grep -qF "columns t,tag,rssi,azimuth,elevation,rssi2,channel,anchor, time in ms" old.err ||
  fail "older layout: the columns said: $(cat old.err)"

# --- --columns and --time-unit for a file of another shape ---------------------------------------
printf 'A1 x 1742248940.7 12 -3 T1\n' >cols.txt
"$prog" --capture cols.txt --columns anchor,-,t,azimuth,elevation,tag --time-unit s \
  --separator space --out cols.lcm 2>cols.err || fail "--columns: $(cat cols.err)"
echo "1742248940700000 ips-ble-aoa:cols.txt A1 T1 12 -3 0 0 -1" >want_cols.txt
check_dump cols.lcm want_cols.txt "--columns, --time-unit s, --separator space"

# --- whole +UUDF lines, the quotes doubled (the logger's raw form) -------------------------------
cat >raw.csv <<'EOF2'
Timestamp,Data
2025-04-21T21:59:30.156096,"+UUDF:6C1DEBA3FFAC,-69,16,-7,0,17,""6C1DEBA09949"","""",4336143,5778"
EOF2
"$prog" --capture raw.csv --out raw.lcm 2>raw.err || fail "+UUDF lines: $(cat raw.err)"
echo "1745272770156096 ips-ble-aoa:raw.csv 6C1DEBA09949 6C1DEBA3FFAC 16 -7 -69 17 5778" >want_raw.txt
check_dump raw.lcm want_raw.txt "whole +UUDF lines"

# --- nothing silent ------------------------------------------------------------------------------
tr ',' ';' <a1.csv >semi.csv
expect_import_error "semi.csv: 0 messages from 4 lines; line 2 '1742248940700;6C1DEBA3FFAC;-57;-5;-20;20;6C1DEBA09949;100': header 'Timestamp;Tag;RSSI;Azimuth;Elevation;Channel;Anchor;Sequence' lacks a column of t, tag, azimuth, elevation, anchor (or uudf, a +UUDF line): give --columns (columns t,tag,rssi,azimuth,elevation,channel,anchor,seq); looks semicolon-separated: try --separator ;" \
  "$prog" --capture semi.csv --separator , --out semi.lcm
head -c 3000 /dev/urandom | tr -c 'a-z\n' 'x' >garbage.csv
set +e
err=$("$prog" --capture garbage.csv --out garbage.lcm 2>&1 >/dev/null)
rc=$?
set -e
[ "$rc" -eq 1 ] || fail "garbage: status $rc: $err"
[ "$(printf '%s\n' "$err" | wc -l)" -eq 1 ] || fail "garbage: more than one line: $err"
case $err in "ips-ble-aoa: error: garbage.csv: 0 messages from "*) ;; *) fail "garbage: $err" ;; esac
echo "ok: $err"
printf '%s\n' '1742248940700,6C1DEBA3FFAC,-57,-5,-20,45,6C1DEBA09949,100' \
  '1742248940710,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,101' \
  '1742248940720,6C1DEBA3FFAC,-57,-5,-20,46,6C1DEBA09949,102' >chan.csv
expect_import_error "chan.csv: 2 of 3 rows rejected; line 1 '1742248940700,6C1DEBA3FFAC,-57,-5,-20,45,6C1DEBA09949,100': channel '45' is not a BLE channel 0..39 (columns t,tag,rssi,azimuth,elevation,channel,anchor,seq)" \
  "$prog" --capture chan.csv --out chan.lcm
[ ! -e chan.lcm ] || fail "a failed import wrote a log"

# --- usage errors: one line, status 2 ------------------------------------------------------------
expect_error_saying "--tag-name: 'x' is not HWID=ID" "$prog" --capture a1.csv --tag-name x
expect_error_saying "--columns: " "$prog" --capture a1.csv --columns t,bogus
expect_error_saying "--time-unit: expected s, ms, us or ns, got 'h'" "$prog" --capture a1.csv --time-unit h
expect_error_saying "--separator: expected , ; tab or space, got 'x'" "$prog" --capture a1.csv --separator x
expect_error_saying "--capture: 'a1.csv' is given twice" "$prog" --capture a1.csv a1.csv
expect_error_saying "--columns goes with --capture" "$prog" --device /dev/null --columns t
echo "PASS"
