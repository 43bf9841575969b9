#!/usr/bin/env bash
# ips-phone-imu start-up errors: each is one line "ips-phone-imu: error: <what>" and status 2,
# before anything is opened; --help is status 0 and lists every flag.
set -euo pipefail
BIN=$(cd "$1" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
export LCM_DEFAULT_URL="memq://"
touch "$WORK/f.txt"

refuse() {  # expected-text args...
  local want=$1 rc=0 err
  shift
  err=$("$BIN/ips-phone-imu" "$@" 2>&1 >/dev/null) || rc=$?
  [ "$rc" -eq 2 ] || fail "ips-phone-imu $*: status $rc (expected 2): $err"
  [ "$(echo "$err" | wc -l)" -eq 1 ] || fail "ips-phone-imu $*: more than one line: $err"
  [[ "$err" == "ips-phone-imu: error: "* ]] || fail "ips-phone-imu $*: not an error line: $err"
  echo "$err" | grep -qF -- "$want" || fail "ips-phone-imu $*: '$err' does not say '$want'"
  echo "ok: $err"
}
refuse "give --udp-port and/or --http-port, or --file"
refuse "--file excludes --udp-port and --http-port" --file "$WORK/f.txt" --udp-port 5555
refuse "--udp-port" --udp-port 0
refuse "--http-port" --http-port 70000
refuse "--columns: unknown column 'qx'" --udp-port 5555 --columns t,qx
refuse "--columns: no t (time) column" --udp-port 5555 --columns ax,ay,az
refuse "--columns: accelerometer needs all three axes or none" --file "$WORK/f.txt" \
  --file-columns t,ax
refuse "--columns: accelerometer needs all three axes or none" --file "$WORK/f.txt" --columns t,ax
refuse "--columns: --rate is for a file without a time column" --file "$WORK/f.txt" --rate 100 \
  --columns t,ax,ay,az
refuse "--time-unit: expected s, ms, us or ns, got 'min'" --file "$WORK/f.txt" --time-unit min
refuse "--separator: expected , ; tab or space, got 'x'" --file "$WORK/f.txt" --separator x
refuse "--file-start: '2024-13-01' is not a Unix time" --file "$WORK/f.txt" --file-start 2024-13-01
refuse "--rate goes with --file" --udp-port 5555 --rate 100
refuse "--file-columns is the old name of --columns" --file "$WORK/f.txt" --columns t,ax,ay,az \
  --file-columns t,ax,ay,az
refuse "--udp-time-unit: expected s, ms, us or ns, got 'min'" --udp-port 5555 --udp-time-unit min
refuse "--gyro-unit: expected rad/s or deg/s, got 'dps'" --udp-port 5555 --gyro-unit dps
refuse "--accel-unit: expected m/s2 or g, got 'G'" --udp-port 5555 --accel-unit G
refuse "--mag-unit: expected uT or mG, got 'T'" --udp-port 5555 --mag-unit T
refuse "--assemble: expected accel or per-sample, got 'all'" --udp-port 5555 --assemble all
refuse "--device-id: 'a b' is not 1 to 64 of A-Za-z0-9_.:-" --udp-port 5555 --device-id "a b"
refuse "--udp-bind: 'localhost' is not an IPv4 address" --udp-port 5555 --udp-bind localhost
refuse "--http-bind: '1.2.3' is not an IPv4 address" --http-port 5555 --http-bind 1.2.3
refuse "--http-path: 'data' is not a path such as /data" --http-port 5555 --http-path data
refuse "--udp-bind goes with --udp-port" --http-port 5555 --udp-bind 0.0.0.0
refuse "--json-accel goes with --http-port" --udp-port 5555 --json-accel accelerometer
refuse "--out goes with --file" --udp-port 5555 --out "$WORK/x.lcm"
refuse "--speed goes with --file" --http-port 5555 --speed 2
refuse "--out excludes --speed" --file "$WORK/f.txt" --out "$WORK/x.lcm" --speed 2
refuse "--max-body-bytes" --http-port 5555 --max-body-bytes 10
refuse "--file: cannot read '$WORK/missing.txt': No such file or directory" --file "$WORK/missing.txt"
refuse "--file: '$WORK' is a directory" --file "$WORK"
refuse "--file-start-s: not a Unix time in seconds" --file "$WORK/f.txt" --file-start-s -5
refuse "--channel: unknown kind" --udp-port 5555 --channel IMUX=X

out=$("$BIN/ips-phone-imu" --help) || fail "--help: status $?"
for flag in --udp-port --udp-bind --columns --udp-time-unit --max-datagram-bytes --http-port \
  --http-bind --http-path --max-body-bytes --max-connections --max-connections-per-peer \
  --header-timeout --json-accel --json-gyro --json-mag \
  --file --file-columns --file-time-unit --file-start-s --out --speed --as-fast-as-possible \
  --separator --header --time-unit --file-start --rate \
  --accel-unit --gyro-unit --mag-unit --assemble --pair-window-s --clock-window-s --clock-jump-s \
  --device-id --lcm-url --channel --log-level; do
  grep -q -- "$flag" <<<"$out" || fail "--help does not list $flag"
done
echo "ok: --help lists every flag"
