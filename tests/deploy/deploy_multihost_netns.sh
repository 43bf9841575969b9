#!/usr/bin/env bash
# Three lab machines on one LAN, for real: three network namespaces (each with its own hostname,
# a UTS namespace) joined by a bridge in a fourth through veth pairs, LCM multicast between them
# with ttl=1. Each "machine" runs `ips-deploy run` on its part of one deployment file:
#   sensors  (host-a): ips-sim, the lab, in place of the drivers
#   compute  (host-b): ips-uwb-twr and ips-fuse
#   recorder (host-c): ips-record
# Checks: `ips-deploy status` on host-c sees every process on its host; the recording on host-c
# holds every channel and its POSE_UWB and POSE_FUSED meet the lab bound (ips-eval: horizontal
# RMSE <= 0.15 m, p95 <= 0.30 m); ips-uwb-twr on host-b, killed with SIGKILL, is restarted by
# ips-deploy (a new pid in HEALTH) and its estimates resume.
# Exit 77 (skipped) when network namespaces cannot be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
fail() { echo "FAIL: $*" >&2; exit 1; }
export PYTHONPATH="$ROOT/tests/integration"

NS="ipsd$$"
if ! ip netns add "${NS}s" 2>/dev/null; then
  echo "SKIP: cannot create network namespaces here (needs root and iproute2)"
  exit 77
fi
WORK=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  sleep 0.5
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  # Whatever ips-deploy started (in its own process groups) goes with the namespaces.
  for n in a b c; do
    for p in $(ip netns pids "$NS$n" 2>/dev/null); do kill -KILL "$p" 2>/dev/null || true; done
  done
  for n in a b c s; do ip netns del "$NS$n" 2>/dev/null || true; done
  rm -rf "$WORK"
}
trap cleanup EXIT

# The switch: a bridge (multicast snooping off: no IGMP querier on this LAN).
ip -n "${NS}s" link add br0 type bridge mcast_snooping 0
ip -n "${NS}s" link set br0 up
i=1
for n in a b c; do
  ip netns add "$NS$n"
  ip link add name eth0 netns "$NS$n" type veth peer name "port-$n" netns "${NS}s"
  ip -n "${NS}s" link set "port-$n" master br0
  ip -n "${NS}s" link set "port-$n" up
  ip -n "$NS$n" link set lo up
  ip -n "$NS$n" addr add "10.77.0.$i/24" dev eth0
  ip -n "$NS$n" link set eth0 up
  ip -n "$NS$n" route add 224.0.0.0/4 dev eth0
  i=$((i + 1))
done
URL="udpm://239.255.76.67:7667?ttl=1&recv_buf_size=4194304"

# on HOST CMD...: CMD on machine HOST (a, b or c), whose hostname is host-HOST.
on() {
  local n=$1
  shift
  ip netns exec "$NS$n" unshare --uts sh -c 'hostname "$0"; exec "$@"' "host-$n" "$@"
}
# start_on HOST CMD... &: the same in the background, the subshell replaced by CMD, so that $!
# is CMD's pid and a signal to it reaches CMD.
start_on() {
  local n=$1
  shift
  exec ip netns exec "$NS$n" unshare --uts sh -c 'hostname "$0"; exec "$@"' "host-$n" "$@"
}

cat >"$WORK/lab.yaml" <<EOF
name: lab
lcm_url: "$URL"
bin_dir: $BIN
restart: {initial_s: 1, max_s: 8}
hosts:
  - name: sensors
    hostname: host-a
    processes:
      - name: sim
        command: ips-sim
        args: [--scenario, lab, --seed, "1", --duration, "40", --log-level, warn]
        restart: "no"
  - name: compute
    hostname: host-b
    processes:
      - name: uwb-twr
        command: ips-uwb-twr
        args: [--log-level, warn]
      - name: fuse
        command: ips-fuse
        args: [--log-level, warn]
  - name: recorder
    hostname: host-c
    processes:
      - name: record
        command: ips-record
        args: [--out, $WORK/host-c.lcm, --site-wait, "0", --log-level, warn]
EOF
"$BIN/ips-deploy" check "$WORK/lab.yaml"

start_on c "$BIN/ips-deploy" run "$WORK/lab.yaml" --host recorder >"$WORK/c.out" 2>&1 & pids+=($!)
start_on b "$BIN/ips-deploy" run "$WORK/lab.yaml" --host compute >"$WORK/b.out" 2>&1 & deploy_b=$!
pids+=($deploy_b)

# status_json: ips-deploy status on host-c.
status_json() { on c "$BIN/ips-deploy" status "$WORK/lab.yaml" --wait 2 --json || true; }
# field PROGRAM KEY < json: the value for the process running PROGRAM.
field() {
  python3 -c '
import json, sys
r = json.load(sys.stdin)
print(next((str(p[sys.argv[2]]) for p in r["processes"] if p["program"] == sys.argv[1]), ""))' "$1" "$2"
}
# Up: each sends HEALTH (the trackers say "starting" until the simulator's SITE comes).
up() { [ "$(echo "$1" | field "$2" pid)" -gt 0 ] 2>/dev/null; }
# Each status listens 2 s: at most 60 s.
for _ in $(seq 30); do
  s=$(status_json)
  up "$s" ips-uwb-twr && up "$s" ips-fuse && up "$s" ips-record && break
done
up "$s" ips-uwb-twr && up "$s" ips-fuse && up "$s" ips-record ||
  fail "compute and recorder did not come up: $s"

start_on a "$BIN/ips-deploy" run "$WORK/lab.yaml" --host sensors >"$WORK/a.out" 2>&1 & deploy_a=$!
pids+=($deploy_a)
# Until the simulator is up and the tracker has its SITE (no longer "starting"): at most 60 s.
sim_on() { up "$1" ips-sim && [[ "$(echo "$1" | field ips-uwb-twr state)" =~ ^(ok|degraded)$ ]]; }
for _ in $(seq 30); do
  s=$(status_json)
  sim_on "$s" && break
done
sim_on "$s" || fail "the simulator did not start, or ips-uwb-twr got no SITE: $s"

# Every process on its machine, as host-c sees it.
on c "$BIN/ips-deploy" status "$WORK/lab.yaml" --wait 2 >"$WORK/status.txt" ||
  fail "ips-deploy status: $(cat "$WORK/status.txt")"
cat "$WORK/status.txt"
python3 - "$WORK/status.txt" <<'EOF'
import re, sys
text = open(sys.argv[1]).read()
hosts = dict(re.findall(r'^host (\S+)\n((?:  .*\n)+)', text, re.M))
expect = {'sensors': ['sim', 'ips-sim'], 'compute': ['uwb-twr', 'ips-uwb-twr', 'fuse', 'ips-fuse'],
          'recorder': ['record', 'ips-record']}
for host, words in expect.items():
    assert host in hosts, f'no host {host} in the status'
    for w in words + ['ips-deploy']:
        assert re.search(rf'\b{re.escape(w)}\b', hosts[host]), f'{w} not listed on {host}'
assert '4 of 4 expected processes heard' in text, text
print('status: every process on its host')
EOF

# Kill the tracker on host-b; ips-deploy restarts it.
s=$(status_json)
old=$(echo "$s" | field ips-uwb-twr pid)
[ -n "$old" ] && [ "$old" -gt 0 ] || fail "no pid for ips-uwb-twr: $s"
kill -KILL "$old"
killed_at=$(date +%s%6N)
new=
for _ in $(seq 30); do
  s=$(status_json)
  new=$(echo "$s" | field ips-uwb-twr pid)
  [ -n "$new" ] && [ "$new" != "$old" ] && [ "$(echo "$s" | field ips-uwb-twr state)" = ok ] && break
done
[ -n "$new" ] && [ "$new" != "$old" ] || fail "ips-uwb-twr was not restarted (pid $old, now '$new')"
grep -q "uwb-twr exited with signal 9 (SIGKILL) after .*; restarting in 1 s" "$WORK/b.out" ||
  fail "host-b's ips-deploy did not report the restart: $(cat "$WORK/b.out")"
echo "ips-uwb-twr pid $old killed, restarted as pid $new"

# The simulation (40 s) ends; sensors' ips-deploy then has nothing left to run.
wait "$deploy_a" || fail "host-a's ips-deploy exited with status $?: $(cat "$WORK/a.out")"
# Until the recording holds the trackers' estimates up to the end of the simulation (or each
# has handled its last input: HEALTH's msgs_in unchanged between two reports).
for pair in POSE_UWB:ips-uwb-twr POSE_FUSED:ips-fuse; do
  python3 "$ROOT/tests/integration/log_wait.py" "$WORK/host-c.lcm" --reach "${pair%%:*}" \
    --end-after-site 40 --or-idle "${pair#*:}" --pid "${pids[0]}"
done
for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null || true; done
for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
pids=()
grep -q "record stopped (status 0)" "$WORK/c.out" || fail "ips-record did not stop cleanly: $(cat "$WORK/c.out")"

python3 - "$WORK/host-c.lcm" "$killed_at" <<'EOF'
import sys, lcm_log
events, _, _ = lcm_log.events(sys.argv[1])
killed = int(sys.argv[2])
channels = {e[0] for e in events}
want = {'SITE', 'TRUTH', 'UWB_RANGE', 'UWB_RX', 'BLE_AOA', 'IMU', 'BARO', 'INS_MODULE',
        'POSE_UWB', 'POSE_FUSED', 'HEALTH'}
assert want <= channels, f'missing from host-c log: {sorted(want - channels)}'
after = [e[1] for e in events if e[0] == 'POSE_UWB' and e[1] > killed + 3_000_000]
assert len(after) >= 100, f'only {len(after)} POSE_UWB after the restart'
print(f'host-c log: {len(events)} events on {len(channels)} channels; '
      f'{len(after)} POSE_UWB from 3 s after the kill on')
EOF

"$BIN/ips-eval" --json "$WORK/host-c.lcm" >"$WORK/eval.json"
python3 - "$WORK/eval.json" <<'EOF2'
import json, sys
rows = json.load(open(sys.argv[1]))["rows"]
bad = []
for ch in ("POSE_UWB", "POSE_FUSED"):
    r = next((r for r in rows if r["channel"] == ch), None)
    if r is None:
        bad.append(f"no {ch} scored")
        continue
    ok = r["count"] >= 200 and r["rmse_h"] <= 0.15 and r["p95_h"] <= 0.30
    verdict = "ok" if ok else "FAIL"
    print(f"{ch}: {r['count']} estimates, rmse_h {r['rmse_h']:.3f} m, p95_h {r['p95_h']:.3f} m "
          f"(bounds 0.15, 0.30): {verdict}")
    if not ok:
        bad.append(ch)
sys.exit("FAIL: lab bound missed: " + ", ".join(bad) if bad else 0)
EOF2
echo "deploy_multihost_netns: ok"
