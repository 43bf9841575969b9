#!/usr/bin/env bash
# ips-baro --file on small hand-made recordings (issue 21): a baro-loruro-like log (banner,
# header, 0.001 hPa rows, trailer) through the documented command line, its rate from the dates,
# a "P <Pa> T <degC>" log, two files with a reference station, stdin, --start-reference; exact
# values and times in the LCM log written. A wrongly separated file and garbage give status 1 and
# one line with the exact hint; usage errors status 2.
#   baro_file_cli.sh BIN_DIR              the hand-made files
#   baro_file_cli.sh BIN_DIR --realdata   the real baro-loruro oss_0.log (GPL-3.0, read in place
#                                         from $IPS_REALDATA or ../shared/realdata; 77 if absent)
set -euo pipefail
bin=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
source "$here/cli_test_lib.sh"
baro=$bin/ips-baro
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"

# The BARO messages of an LCM log, one line each: sensor utime pressure temperature humidity
# is_reference known_height (decoded by the independent Python readers).
dump() {
  PYTHONPATH=$here python3 - "$1" <<'PY'
import sys, lcm_log, lcm_messages
evs, _, _ = lcm_log.events(sys.argv[1])
for ch, ts, data in evs:
    m = lcm_messages.baro(data)
    print(ch, m['sensor_id'], m['utime'], '%.3f' % m['pressure_pa'], '%.3f' % m['temperature_c'],
          '%.1f' % m['humidity_pct'], int(m['is_reference']), '%.2f' % m['known_height_m'])
PY
}
# expect_import_error TEXT CMD...: status 1 and exactly one line "ips-baro: error: TEXT".
expect_import_error() {
  local text=$1 rc
  shift
  set +e
  err=$("$@" 2>&1 >/dev/null)
  rc=$?
  set -e
  [ "$rc" -eq 1 ] || fail "$*: status $rc (expected 1): $err"
  [ "$err" = "ips-baro: error: $text" ] || fail "$*: expected 'ips-baro: error: $text', got: $err"
  echo "ok: $err"
}

if [ "${2:-}" = "--realdata" ]; then
  root=${IPS_REALDATA:-$here/../../../shared/realdata}
  folder=$root/baro-loruro/measurements/in_place
  if [ ! -f "$folder/oss_0.log" ]; then
    echo "SKIP: no $folder/oss_0.log (baro-loruro is GPL-3.0: read in place, set IPS_REALDATA)"
    exit 77
  fi
  "$baro" --file "$folder/oss_0.log" --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC \
    --rate 10 --out baro.lcm 2>err.txt || fail "oss_0.log: $(cat err.txt)"
  cat err.txt
  rows=$(grep -c '^[0-9]*;[0-9]*;[0-9]*' "$folder/oss_0.log")  # counted independently
  [ "$rows" -eq 2595 ] || fail "oss_0.log has $rows rows, expected 2595"
  grep -q "oss_0.log: 2603 lines, 2595 rows, 2595 used, 0 rejected" err.txt || fail "summary"
  dump baro.lcm >got.txt
  [ "$(awk '$2 == "T1"' got.txt | wc -l)" -eq 2595 ] || fail "T1 samples"
  # Rows 0.1 s apart from the banner's start, 16:41:18 (read as UTC).
  [ "$(awk '$2 == "T1" && n++ < 2 {printf "%s ", $3}' got.txt)" = \
    "1465836078000000 1465836078100000 " ] || fail "T1 times"
  # Without --rate: the dates and the row count give the rate.
  "$baro" --file "$folder/oss_0.log" --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC \
    --out baro2.lcm 2>err.txt || fail "oss_0.log without --rate: $(cat err.txt)"
  grep -q "evenly: 8.676 Hz" err.txt || fail "derived rate: $(cat err.txt)"
  echo "PASS (real oss_0.log)"
  exit 0
fi

# --- a baro-loruro-like log: CRLF, banner, header, trailer; the MPL column 0 in one row --------
printf '%s\r\n' "Terminal log file" "Date: 13-06-2016 - 16:41:18" \
  "-----------------------------------------------" \
  "MPL115A1_Pressure;BMP180_Pressure;BMP180_Temperature" \
  "967128;973004;26525" "966294;972795;26525" "0;972900;26530" "966300;972850;26530" \
  "966310;972860;26535" "" "-----------------------------------------------" \
  "Date: 13-06-2016 - 16:41:20" "End log file" >oss_0.log
"$baro" --file oss_0.log --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC --rate 10 \
  --out baro.lcm 2>err.txt || fail "loruro-like: $(cat err.txt)"
cat err.txt
grep -qF "ips-baro: oss_0.log: 13 lines, 5 rows, 5 used, 0 rejected; 9 samples over 0.4 s; times from --rate 10 Hz from 2016-06-13T16:41:18Z (the banner's start date); 5 rows from 2016-06-13T16:41:18Z (the banner's start date) to 2016-06-13T16:41:20Z (the trailer's end date) say 2.000 Hz" err.txt ||
  fail "summary line"
grep -qF "ips-baro: oss_0.log: sensor mpl: 4 samples, pressure mean 96650.80 Pa" err.txt ||
  fail "mpl line"
grep -qF "1 rejected (first: line 7: mpl: pressure 0 Pa is not positive)" err.txt ||
  fail "mpl rejection counted"
dump baro.lcm >got.txt
cat >want.txt <<'W'
BARO T1 1465836078000000 97300.400 26.525 nan 0 nan
BARO mpl 1465836078000000 96712.800 nan nan 0 nan
BARO T1 1465836078100000 97279.500 26.525 nan 0 nan
BARO mpl 1465836078100000 96629.400 nan nan 0 nan
BARO T1 1465836078200000 97290.000 26.530 nan 0 nan
BARO T1 1465836078300000 97285.000 26.530 nan 0 nan
BARO mpl 1465836078300000 96630.000 nan nan 0 nan
BARO T1 1465836078400000 97286.000 26.535 nan 0 nan
BARO mpl 1465836078400000 96631.000 nan nan 0 nan
W
diff want.txt got.txt || fail "loruro-like messages"
echo "ok: loruro-like log, --rate 10"

# Without --rate: 5 rows between the banner's 16:41:18 and the trailer's 16:41:20 -> 2 Hz.
"$baro" --file oss_0.log --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC --device bmp \
  --out rate.lcm 2>err.txt || fail "derived rate: $(cat err.txt)"
grep -qF "evenly: 2.000 Hz (--rate HZ to override)" err.txt || fail "derived rate: $(cat err.txt)"
[ "$(dump rate.lcm | awk '$2 == "bmp" {print $3}' | tail -1)" = 1465836080000000 ] ||
  fail "the last row is not at the end date"
echo "ok: rate from the banner dates"

# --- the serial line format, with --rate and --file-start; a bad line counted -----------------
printf '%s\n' "# BME280 sketch" "P 101325.12 T 21.43 H 45.2" "P 0 T 21.4" "P 101320.5 T 21.50" \
  >pt.log
"$baro" --file pt.log --device T2 --rate 5 --file-start 2024-01-01T00:00:00Z --out pt.lcm \
  2>err.txt || fail "P/T log: $(cat err.txt)"
grep -qF "pt.log: 4 lines, 3 rows, 2 used, 1 rejected (first: line 3: pressure 0 Pa is not positive)" err.txt ||
  fail "P/T summary: $(cat err.txt)"
dump pt.lcm >got.txt
printf '%s\n' "BARO T2 1704067200000000 101325.120 21.430 45.2 0 nan" \
  "BARO T2 1704067200400000 101320.500 21.500 nan 0 nan" >want.txt
diff want.txt got.txt || fail "P/T messages"
echo "ok: P/T log"

# --- two files, one a reference station; columns with a time column and hPa ------------------
printf '%s\n' "time,pressure_hpa,temp" "1704067200.0,1013.00,20.0" "1704067200.5,1013.01,20.0" \
  >ref.csv
printf '%s\n' "time,pressure_hpa,temp" "1704067200.25,1012.80,21.0" >tag.csv
"$baro" --file B1=ref.csv --file T1=tag.csv --columns time,p,t --units s,hPa,degC \
  --reference B1=1.5 --out two.lcm 2>err.txt || fail "two files: $(cat err.txt)"
dump two.lcm >got.txt
printf '%s\n' "BARO B1 1704067200000000 101300.000 20.000 nan 1 1.50" \
  "BARO T1 1704067200250000 101280.000 21.000 nan 0 nan" \
  "BARO B1 1704067200500000 101301.000 20.000 nan 1 1.50" >want.txt
diff want.txt got.txt || fail "two files merged in time order"
echo "ok: two files, a reference station"

# --- stdin, and --start-reference (the mean of T1's first second: both rows) -----------------
cat pt.log | "$baro" --file - --rate 5 --file-start 1704067200 --start-reference T1 \
  --out stdin.lcm 2>err.txt || fail "stdin: $(cat err.txt)"
grep -qF "ips-baro: stdin: 4 lines, 3 rows" err.txt || fail "stdin summary: $(cat err.txt)"
dump stdin.lcm >got.txt
printf '%s\n' "BARO T1.start 1704067200000000 101322.810 21.465 nan 1 0.00" \
  "BARO T1 1704067200000000 101325.120 21.430 45.2 0 nan" \
  "BARO T1.start 1704067200400000 101322.810 21.465 nan 1 0.00" \
  "BARO T1 1704067200400000 101320.500 21.500 nan 0 nan" >want.txt
diff want.txt got.txt || fail "stdin with --start-reference"
echo "ok: stdin, --start-reference"

# --- on the bus instead of --out (LCM's in-process memq: no network needed), as fast as
# possible and paced by the file's times -----------------------------------------------------
for speed in 0 1; do
  "$baro" --file pt.log --rate 5 --file-start 1704067200 --lcm-url memq:// --speed $speed \
    2>err.txt || fail "bus, --speed $speed: $(cat err.txt)"
  grep -qx "ips-baro: published 2 messages on BARO" err.txt || fail "bus: $(cat err.txt)"
done
echo "ok: published on the bus"

# --- nothing silent ------------------------------------------------------------------------
printf '%s\n' "967128;973004;26525" "966294;972795;26525" "966300;972850;26530" >semicolon.log
expect_import_error "semicolon.log: 0 messages from 3 lines; line 1 '967128;973004;26525': 1 fields, expected 3 (mpl.p,p,t) (columns mpl.p,p,t); looks semicolon-separated: try --separator ;" \
  "$baro" --file semicolon.log --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC --rate 10 \
  --separator , --out x.lcm
expect_import_error "semicolon.log: 0 messages from 3 lines; line 1 '967128;973004;26525': 1 fields, expected 3 (mpl.p,p,t) (columns mpl.p,p,t); looks semicolon-separated: try --separator ;" \
  "$baro" --file semicolon.log --columns mpl,p,t --units 0.001hPa,0.001hPa,0.001degC --rate 10 \
  --separator , --header none --out x.lcm
PYTHONPATH=$here python3 "$here/lcm_log.py" garbage 3000 >garbage.bin
set +e
err=$("$baro" --file garbage.bin --rate 10 --out x.lcm 2>&1 >/dev/null)
rc=$?
set -e
[ "$rc" -eq 1 ] || fail "garbage: status $rc: $err"
[ "$(printf '%s\n' "$err" | wc -l)" -eq 1 ] || fail "garbage: more than one line: $err"
case $err in "ips-baro: error: garbage.bin: 0 messages from "*) ;; *) fail "garbage: $err" ;; esac
echo "ok: $err"
# Units in the wrong scale: every pressure outside 30..125 kPa, the import fails.
expect_import_error "oss_0.log: 0 messages from 13 lines; line 5 '967128;973004;26525': T1: pressure 973004 Pa is outside 30..125 kPa, the measuring range of the supported sensors (columns mpl.p,p,t); check --units (e.g. 0.001hPa)" \
  "$baro" --file oss_0.log --columns mpl,p,t --rate 10 --out x.lcm
expect_import_error "pt.log: the rows have no time: give --rate HZ (and --file-start T), or --columns with a time column" \
  "$baro" --file pt.log --out x.lcm
[ ! -e x.lcm ] || fail "a failed import wrote a log"
: >empty.log
expect_import_error "empty.log: 0 samples from 0 lines (an empty file?)" \
  "$baro" --file empty.log --rate 1 --out x.lcm

# --- usage errors: status 2, one line -------------------------------------------------------
expect_error_saying "--units has 2 entries for 3 columns" \
  "$baro" --file oss_0.log --columns mpl,p,t --units 0.001hPa,0.001hPa
expect_error_saying "--file replaces --iio and --serial" "$baro" --file oss_0.log --iio T1=bmp280
expect_error_saying "--columns, --units" "$baro" --iio T1=bmp280 --columns p,t
expect_error_saying "with several files give each its sensor id (--file ID=F)" \
  "$baro" --file a.log --file b.log
expect_error_saying "cannot read 'missing.log'" "$baro" --file missing.log --rate 1
expect_error_saying "--speed paces publishing on the bus: it does not go with --out" \
  "$baro" --file pt.log --rate 1 --out x.lcm --speed 2
expect_error_saying "--start-reference X: no such sensor" "$baro" --file pt.log --rate 1 \
  --start-reference X
echo PASS
