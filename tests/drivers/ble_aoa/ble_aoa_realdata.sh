#!/usr/bin/env bash
# ips-ble-aoa --capture on a real recording of Byongho96/ble-localization (no licence: read in
# place from $IPS_REALDATA or ../shared/realdata relative to the repository, never copied; skipped,
# status 77, when absent): one anchor's file of decoded +UUDF fields through the documented
# command line, its import counts asserted.
#   ble_aoa_realdata.sh BIN_DIR
set -euo pipefail
bin=$(cd "$1" && pwd)
root=$(cd "$(dirname "$0")/../../.." && pwd)
data=${IPS_REALDATA:-$root/../shared/realdata}/ble-byongho96/dataset
file=$data/0317/anchor1/rectangular.csv
if [ ! -f "$file" ]; then
  echo "SKIP: $file is absent (set IPS_REALDATA to the real recordings)"
  exit 77
fi
fail() { echo "FAIL: $*" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$bin/ips-ble-aoa" --capture "$file" --anchor-name 6C1DEBA09949=A1 --tag-name 6C1DEBA3FFAC=T1 \
  --out "$tmp/a1.lcm" 2>"$tmp/err" || fail "status $?: $(cat "$tmp/err")"
want="rectangular.csv: 8984 rows (columns t,tag,rssi,azimuth,elevation,channel,anchor,seq, time in ms), 8984 events from 2025-03-17T22:02:20Z to 2025-03-17T22:10:02Z, 0 duplicates dropped, 0 dropped (angle range unknown), 0 rows rejected"
grep -qF "$want" "$tmp/err" || fail "expected '$want' in: $(cat "$tmp/err")"
echo "ok: $(grep -F 'rectangular.csv:' "$tmp/err")"
