#!/usr/bin/env bash
# ips-baro start-up errors: each is one line "ips-baro: error: <what>" and status 2, before any
# sample is read (bad flags, bad sensor specs, IIO devices that cannot be found or used, reference
# stations without a height, a bad site file, a serial path that is no terminal); --help is
# status 0 and lists every flag.
set -euo pipefail
BIN=$(cd "$1" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
source "$(dirname "$0")/../../integration/cli_test_lib.sh"
export LCM_DEFAULT_URL="memq://"

SYS="$WORK/sys"
device() {  # device ENTRY NAME ATTR...: a fake IIO device, every attribute a plausible value
  mkdir -p "$SYS/$1"
  printf '%s\n' "$2" >"$SYS/$1/name"
  local a
  for a in "${@:3}"; do printf '100\n' >"$SYS/$1/$a"; done
}
device iio:device0 lsm6dsl in_accel_x_raw in_accel_scale
device iio:device1 bmp280 in_pressure_input in_temp_input
device iio:device2 bmp388 in_pressure_input in_temp_input
device iio:device3 bmp388 in_pressure_input in_temp_input
printf 'anchors:\n  - {id: A1, position: [0, 0, 2.4]}\nbaro_stations:\n  - {id: B9, position: [0, 0, 2.4]}\n' \
  >"$WORK/lab.yaml"
printf 'anchors: [\n' >"$WORK/broken.yaml"

refuse() {  # expected-text args...
  expect_error_saying "$1" "$BIN/ips-baro" "${@:2}"
}
I=(--sysfs-root "$SYS")
refuse "give --iio and/or --serial (one per sensor)"
refuse "--rate-hz goes with --iio" --serial "T2=$WORK/tty" --rate-hz 5
refuse "--oversampling goes with --iio" --serial "T2=$WORK/tty" --oversampling 4
refuse "--sysfs-root goes with --iio" --serial "T2=$WORK/tty" --sysfs-root "$SYS"
refuse "--baud goes with --serial" "${I[@]}" --iio T1=bmp280 --baud 9600
refuse "--iio: 'bmp280' is not ID=NAME or ID=PATH (e.g. T1=bmp280 or B1=/sys/bus/iio/devices/iio:device1)" \
  --iio bmp280
refuse "--iio: 'T 1=bmp280' is not ID=NAME or ID=PATH (ID: 1 to 32 of A-Za-z0-9_.:-)" --iio "T 1=bmp280"
refuse "--serial: '/dev/ttyUSB0' is not ID=PATH (ID: 1 to 32 of A-Za-z0-9_.:-)" --serial /dev/ttyUSB0
refuse "--serial T2=$WORK: is a directory" --serial "T2=$WORK"
refuse "--serial T2=$WORK/lab.yaml: is a regular file, not a serial device" --serial "T2=$WORK/lab.yaml"
refuse "--serial T2=/dev/null: not a terminal (serial) device" --serial T2=/dev/null
refuse "--baud: 12345 is not a speed termios can set (e.g. 9600, 115200, 921600)" \
  --serial "T2=$WORK/tty" --baud 12345
refuse "sensor id T1 is given twice" "${I[@]}" --iio T1=bmp280 --serial "T1=$WORK/tty"
refuse "--serial $WORK/tty is given twice" --serial "T1=$WORK/tty" --serial "T2=$WORK/tty"
refuse "--reference: 'B1=high': the height is not a number of metres within +-10000 (e.g. B1=2.4)" \
  "${I[@]}" --iio B1=bmp280 --reference B1=high
refuse "--reference X9: no sensor X9 (give it with --iio, --serial or a --file column)" "${I[@]}" --iio B1=bmp280 \
  --reference X9=1
refuse "--reference B1 is given twice" "${I[@]}" --iio B1=bmp280 --reference B1=1 --reference B1=2
refuse "--reference B1: no height: give B1=HEIGHT_M, or --site with a baro_stations entry B1" \
  "${I[@]}" --iio B1=bmp280 --reference B1
refuse "--reference B1: no height: the site $WORK/lab.yaml has no baro_stations entry B1 (it has B9); or give B1=HEIGHT_M" \
  "${I[@]}" --iio B1=bmp280 --reference B1 --site "$WORK/lab.yaml"
refuse "$WORK/broken.yaml" "${I[@]}" --iio B1=bmp280 --site "$WORK/broken.yaml"
refuse "$WORK/missing.yaml" "${I[@]}" --iio B1=bmp280 --site "$WORK/missing.yaml"
refuse "--iio T1=bmp180: no IIO device named 'bmp180' in $SYS (found: iio:device0 'lsm6dsl', iio:device1 'bmp280', iio:device2 'bmp388', iio:device3 'bmp388')" \
  "${I[@]}" --iio T1=bmp180
refuse "--iio T1=bmp388: 2 IIO devices are named 'bmp388' ($SYS/iio:device2, $SYS/iio:device3): pick one by its path" \
  "${I[@]}" --iio T1=bmp388
refuse "--iio A1=iio:device0: $SYS/iio:device0 ('lsm6dsl') has no in_pressure_input, nor in_pressure_raw with in_pressure_scale: not a barometer" \
  "${I[@]}" --iio A1=iio:device0
refuse "--iio B1=$SYS/iio:device9: $SYS/iio:device9: No such file or directory" \
  "${I[@]}" --iio "B1=$SYS/iio:device9"
refuse "--iio T1 and --iio T2 are the same device $SYS/iio:device1" \
  "${I[@]}" --iio T1=bmp280 --iio "T2=$SYS/iio:device1"
refuse "--iio T1=bmp280: $SYS/iio:device1 has no in_pressure_oversampling_ratio: the kernel driver of 'bmp280' cannot set pressure oversampling" \
  "${I[@]}" --iio T1=bmp280 --oversampling 16
refuse "--iio T1=bmp280: cannot read $WORK/nope: No such file or directory (is the sensor's kernel driver loaded?)" \
  --sysfs-root "$WORK/nope" --iio T1=bmp280
refuse "--rate-hz" "${I[@]}" --iio T1=bmp280 --rate-hz 0
refuse "--oversampling" "${I[@]}" --iio T1=bmp280 --oversampling 0
refuse "--reopen-s" --serial "T2=$WORK/tty" --reopen-s 0
refuse "--channel: unknown kind 'BAROX'" "${I[@]}" --iio T1=bmp280 --channel BAROX=X

out=$("$BIN/ips-baro" --help) || fail "--help: status $?"
for flag in --iio --serial --baud --reopen-s --rate-hz --oversampling --sysfs-root --reference \
  --site --lcm-url --channel --log-level; do
  grep -q -- "$flag" <<<"$out" || fail "--help does not list $flag"
done
echo "ok: --help lists every flag"
