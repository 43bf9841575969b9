#!/usr/bin/env bash
# On a machine without a multicast route, programs stop at once with one line that says what to
# do (the route commands), instead of hanging. Runs in a private network namespace whose
# loopback is up but has no route for 224.0.0.0/4. Exit 77 (skipped) when no namespace can be
# made here.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
if [ "${IPS_IN_NETNS:-}" != "1" ]; then
  if [ "$(id -u)" -eq 0 ]; then args=(--net); else args=(--user --map-root-user --net); fi
  unshare "${args[@]}" true 2>/dev/null || { echo "SKIP: cannot create a network namespace"; exit 77; }
  IPS_IN_NETNS=1 exec unshare "${args[@]}" "$0" "$@"
fi
ip link set lo up
unset LCM_DEFAULT_URL
err=$(mktemp)
trap 'rm -f "$err"' EXIT
failures=0
# ips-fuse with its own receiver (--lcm-receiver direct, its default) and with liblcm's, the
# others through liblcm's.
for cmd in "ips-bus-check" "ips-uwb-twr --site $ROOT/config/sites/lab.yaml" "ips-sim --scenario lab" \
  "ips-fuse --site $ROOT/config/sites/lab.yaml" \
  "ips-fuse --site $ROOT/config/sites/lab.yaml --lcm-receiver liblcm"; do
  start=$(date +%s%N)
  status=0
  # shellcheck disable=SC2086
  timeout 60 "$BIN"/$cmd >/dev/null 2>"$err" || status=$?
  ms=$(( ($(date +%s%N) - start) / 1000000 ))
  lines=$(wc -l <"$err")
  if [ "$status" -eq 1 ] && [ "$lines" -eq 1 ] && [ "$ms" -lt 20000 ] &&
    grep -q "ip route add 224.0.0.0/4 dev lo" "$err"; then
    echo "ok: $cmd -> exit 1 in $ms ms: $(cat "$err")"
  else
    echo "FAIL: $cmd -> exit $status in $ms ms, $lines lines:"; cat "$err"
    failures=$((failures + 1))
  fi

done
echo "$failures failure(s)"
[ "$failures" -eq 0 ]
