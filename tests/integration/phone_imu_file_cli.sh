#!/usr/bin/env bash
# ips-phone-imu --file through core/table_text (issue 21): the documented command lines on the
# real excerpts of tests/data/real (an accelerometer-only phone CSV with ns times since boot, a
# foot-mounted IMU at 820 Hz without a time column), exact messages in the LCM log; a header
# mapped by name; nothing silent: a comma file read with --separator ';', a file in ns read as
# seconds, garbage and an empty result give status 1 and one line with the exact hint.
set -euo pipefail
bin=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
source "$here/cli_test_lib.sh"
imu=$bin/ips-phone-imu
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"
steps=$root/tests/data/real/steps-oxford/Samsung_Jamie_Hard_InHand_1-accelerometer-25s.csv
zcat "$root/tests/data/real/foot-openshoe/OpenShoeDataSet-8s.txt.gz" >foot.txt

# The IMU messages of an LCM log, one line each: utime device_utime device accel gyro mag.
dump() {
  PYTHONPATH=$here python3 - "$1" <<'PY'
import sys, lcm_log
from lcm_messages import _Reader
evs, read, size = lcm_log.events(sys.argv[1])
assert read == size
for ch, ts, data in evs:
    r = _Reader(data)
    utime, source, device, dev_utime = r.take('q'), r.string(), r.string(), r.take('q')
    v = [r.take('d') for _ in range(9)]
    assert ch == 'IMU' and ts == utime and source == 'ips-phone-imu:file'
    print(utime, dev_utime, device, ' '.join('%.6g' % x for x in v))
PY
}
# status 1 and exactly one line "ips-phone-imu: error: <text>".
refuse_import() {
  local text=$1 rc=0 err
  shift
  err=$("$imu" "$@" 2>&1 >/dev/null) || rc=$?
  [ "$rc" -eq 1 ] || fail "$*: status $rc (expected 1)"
  [ "$(printf '%s\n' "$err" | wc -l)" -eq 1 ] || fail "$*: not one error line: $err"
  [ "$err" = "ips-phone-imu: error: $text" ] || fail "$*: got
  $err
expected
  ips-phone-imu: error: $text"
  echo "ok: status 1: $err"
}

# 1. Accelerometer only (steps-oxford): --columns skips the accuracy, ns times since boot.
"$imu" --file "$steps" --columns t,-,ax,ay,az --time-unit ns --out steps.lcm 2>steps.err ||
  fail "steps: status $?: $(cat steps.err)"
grep -qF "2500 rows read, 2500 messages written to steps.lcm, 0 rows rejected, 376.185 to 401.175 s (25.0 s)" steps.err ||
  fail "steps: summary: $(cat steps.err)"
grep -qF "comma-separated (detected), columns t,-,ax,ay,az (from --columns), times in ns (--time-unit)" steps.err ||
  fail "steps: what was used: $(cat steps.err)"
grep -qF "give --file-start to place them" steps.err || fail "steps: since boot not said"
dump steps.lcm >steps.txt
[ "$(wc -l <steps.txt)" -eq 2500 ] || fail "steps: $(wc -l <steps.txt) messages"
[ "$(head -1 steps.txt)" = "376184715 376184715 phone -0.350751 5.67426 8.48026 nan nan nan nan nan nan" ] ||
  fail "steps: first message: $(head -1 steps.txt)"
[ "$(tail -1 steps.txt)" = "401174708 401174708 phone 0.439336 4.7477 6.40569 nan nan nan nan nan nan" ] ||
  fail "steps: last message: $(tail -1 steps.txt)"
echo "ok: accelerometer-only CSV, ns since boot: 2500 messages, gyro and mag NaN"

# --file-start places them; ISO-8601 and Unix seconds agree.
"$imu" --file "$steps" --columns t,-,ax,ay,az --time-unit ns --file-start 2019-03-01T10:00:00Z \
  --out iso.lcm 2>/dev/null || fail "--file-start ISO"
"$imu" --file "$steps" --columns t,-,ax,ay,az --time-unit ns --file-start 1551434400 \
  --out unix.lcm 2>/dev/null || fail "--file-start s"
cmp -s iso.lcm unix.lcm || fail "--file-start: ISO-8601 and Unix time differ"
dump iso.lcm >iso.txt
[ "$(head -2 iso.txt | cut -d' ' -f1,2 | tr '\n' ' ')" = "1551434400000000 376184715 1551434400009995 376194710 " ] ||
  fail "--file-start: $(head -2 iso.txt)"
echo "ok: --file-start (ISO-8601 or Unix s) places the first row, spacing kept"

# 2. Foot-mounted IMU (foot-openshoe): no time column, 820 Hz.
"$imu" --file foot.txt --columns ax,ay,az,gx,gy,gz --rate 820 --device-id foot1 \
  --out foot.lcm 2>foot.err || fail "foot: status $?: $(cat foot.err)"
grep -qF "6560 rows read, 6560 messages written to foot.lcm, 0 rows rejected, 1.000 to 8.999 s (8.0 s)" foot.err ||
  fail "foot: summary: $(cat foot.err)"
dump foot.lcm >foot.txt.dump
[ "$(sed -n 2p foot.txt.dump)" = "1001220 1220 foot1 -0.0326573 -0.424545 9.73188 -0.0244345 0.0209438 -0.0139626 nan nan nan" ] ||
  fail "foot: second message: $(sed -n 2p foot.txt.dump)"
echo "ok: foot IMU at --rate 820: 6560 messages, row k at 1 s + k/820"

# 3. A header mapped by name (semicolons, ms epoch times guessed).
printf 'Timestamp(ms);ACC_X;acc_y;Acc Z\n1700000000000;0;0;9.8\n1700000000010;0;0.5;9.8\n' >hdr.csv
"$imu" --file hdr.csv --out hdr.lcm 2>hdr.err || fail "header: $(cat hdr.err)"
[ "$(dump hdr.lcm | cut -d' ' -f1,5 | tr '\n' ' ')" = "1700000000000000 0 1700000000010000 0.5 " ] ||
  fail "header: $(dump hdr.lcm)"
grep -qF "times in ms (guessed from the first time's magnitude)" hdr.err || fail "header: unit"
echo "ok: header names map the columns"

# 4. Nothing silent.
refuse_import "$steps: 0 messages from 2500 lines; line 1 '376184715063,3,-0.35075054,5.674258,8.480263': 1 fields, expected at least 5 (t,-,ax,ay,az) (columns t,-,ax,ay,az); looks comma-separated: try --separator ," \
  --file "$steps" --columns t,-,ax,ay,az --time-unit ns --separator ';' --out x.lcm
refuse_import "$steps: 0 messages from 2500 lines; line 1 '376184715063,3,-0.35075054,5.674258,8.480263': time '376184715063' is not a time in s (columns t,-,ax,ay,az); check --time-unit, or give --rate HZ for a file without times" \
  --file "$steps" --columns t,-,ax,ay,az --out x.lcm
head -c 3000 /dev/urandom >garbage.bin
printf 'GIF89a\001\002\003 not an imu file\nhello world\n' >garbage.txt
refuse_import "garbage.txt: 0 messages from 2 lines; no line looks like data (the first reads 'GIF89a??? not an imu file'); is this the right file? check --separator, --columns and the header" \
  --file garbage.txt --out x.lcm
rc=0
"$imu" --file garbage.bin --out x.lcm >/dev/null 2>garbage.err || rc=$?
[ "$rc" -eq 1 ] && grep -q "^ips-phone-imu: error: garbage.bin: " garbage.err ||
  fail "random bytes: status $rc: $(cat garbage.err)"
echo "ok: random bytes: status 1"
[ ! -e x.lcm ] || fail "a failed import wrote x.lcm"
expect_error_saying "--columns: --rate is for a file without a time column" \
  "$imu" --file foot.txt --columns t,ax,ay,az --rate 820 --out x.lcm
echo "ok: phone_imu_file_cli"
