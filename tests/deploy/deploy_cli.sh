#!/usr/bin/env bash
# ips-deploy on one machine (LCM memq://, no network needed):
#  1. check and its errors (file:line: field: reason), a host that is not there, a program that
#     is not there;
#  2. systemd: the units written, refused over existing files without --force, and accepted by
#     `systemd-analyze verify` when it is installed (only the two keys systemd 252 does not know
#     yet may be warned about);
#  3. run: output prefixed with the process name, a failing process restarted with a doubling
#     back-off (0.2, 0.4, 0.8 s), a process that ignores SIGINT killed after its stop timeout,
#     SIGTERM stopping everything with status 0, environment and working directory;
#  4. run ends by itself, status 0, when every process has ended cleanly and none restarts;
#  5. SIGHUP stops everything cleanly; a SIGKILLed ips-deploy leaves no process running.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/cli_test_lib.sh"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
D="$BIN/ips-deploy"

cat >"$WORK/d.yaml" <<EOF
name: bench
lcm_url: "memq://"
working_dir: $WORK
environment: {IPS_TEST_GREETING: "hello from"}
hosts:
  - name: pc
    processes:
      - name: flaky
        command: /bin/sh
        args: [-c, 'echo "\$IPS_TEST_GREETING \$(basename "\$PWD") \$IPS_TEST_RUN"; sleep 0.1; exit 3']
        environment: {IPS_TEST_RUN: flaky}
        restart_backoff: {initial_s: 0.2, max_s: 0.8}
      - name: stubborn
        command: /bin/sh
        args: [-c, 'trap "" INT; echo ready; while true; do sleep 0.1; done']
        stop_timeout_s: 0.5
        after: [flaky]
      - name: twr
        command: ips-uwb-twr
        restart: always
EOF

# --- 1: check ------------------------------------------------------------------------------
out=$("$D" check "$WORK/d.yaml")
echo "$out" | grep -q '^host pc (hostname pc), in start order:' || fail "check: $out"
[ "$(echo "$out" | grep -c '^  ')" -eq 3 ] || fail "check lists $(echo "$out" | grep -c '^  ') processes: $out"
printf 'name: x\nlcm_url: "memq://"\nhosts:\n  - name: pc\n    proceses: []\n' >"$WORK/bad.yaml"
expect_error_saying "bad.yaml:5" "$D" check "$WORK/bad.yaml"
expect_error_saying "proceses" "$D" check "$WORK/bad.yaml"
printf 'name: x\nlcm_url: "memq://"\nhosts:\n  - name: pc\n    processes:\n      - {name: a, command: x, after: [b]}\n      - {name: b, command: x, after: [a]}\n' >"$WORK/cycle.yaml"
expect_error_saying "goes round in a circle among: a, b" "$D" check "$WORK/cycle.yaml"
expect_error_saying "no host 'nope' in $WORK/d.yaml (hosts: pc)" "$D" run "$WORK/d.yaml" --host nope
expect_error_saying "cannot read" "$D" check "$WORK/none.yaml"
sed 's|command: ips-uwb-twr|command: ips-no-such-program|' "$WORK/d.yaml" >"$WORK/missing.yaml"
expect_error_saying "process 'twr': no program 'ips-no-such-program'" "$D" run "$WORK/missing.yaml" --host pc

# --- 2: systemd ----------------------------------------------------------------------------
"$D" systemd "$WORK/d.yaml" --host pc --out "$WORK/units" >/dev/null
ls "$WORK/units" | sort >"$WORK/units.list"
printf '%s\n' ips-bench-flaky.service ips-bench-stubborn.service ips-bench-twr.service \
  ips-bench.target | diff - "$WORK/units.list" || fail "unit files"
grep -qx "ExecStart=\"$BIN/ips-uwb-twr\"" "$WORK/units/ips-bench-twr.service" || fail "twr ExecStart"
grep -qx 'After=network-online.target ips-bench-flaky.service' "$WORK/units/ips-bench-stubborn.service" ||
  fail "stubborn's After="
grep -qx 'Environment="LCM_DEFAULT_URL=memq://"' "$WORK/units/ips-bench-twr.service" || fail "LCM URL"
grep -qx 'Restart=always' "$WORK/units/ips-bench-twr.service" || fail "Restart=always"
grep -qx 'RestartSec=0.2s' "$WORK/units/ips-bench-flaky.service" || fail "RestartSec"
expect_error_saying "exists (--force to overwrite)" "$D" systemd "$WORK/d.yaml" --host pc --out "$WORK/units"
"$D" systemd "$WORK/d.yaml" --host pc --out "$WORK/units" --force >/dev/null || fail "--force"
if command -v systemd-analyze >/dev/null; then
  set +e
  verify=$(cd "$WORK/units" && systemd-analyze verify ./*.service ./*.target 2>&1)
  rc=$?
  set -e
  unexpected=$(echo "$verify" | grep -v "Unknown key 'Restart\(Steps\|MaxDelaySec\)' in section \[Service\], ignoring" | grep -v '^$' || true)
  [ "$rc" -eq 0 ] && [ -z "$unexpected" ] || fail "systemd-analyze verify (status $rc): $verify"
  echo "systemd-analyze verify: ok"
else
  echo "systemd-analyze not installed: the units' syntax is not verified"
fi

# The example in config/ is valid, and gives units for each of its hosts.
"$D" check "$ROOT/config/deploy/lab-3-hosts.yaml" >/dev/null || fail "config/deploy/lab-3-hosts.yaml"
for h in sensors compute recorder; do
  "$D" systemd "$ROOT/config/deploy/lab-3-hosts.yaml" --host "$h" --out "$WORK/example-$h" >/dev/null
done
[ "$(ls "$WORK"/example-*/*.service | wc -l)" -eq 6 ] || fail "example: $(ls "$WORK"/example-*)"
grep -qx 'User=ips' "$WORK/example-recorder/ips-lab-record.service" || fail "example: User="

# --- 3: run --------------------------------------------------------------------------------
start=$(date +%s.%N)
"$D" run "$WORK/d.yaml" --host pc >"$WORK/run.out" 2>"$WORK/run.err" & deploy=$!
for _ in $(seq 600); do  # at most 60 s
  [ "$(grep -c '^\[flaky\] hello from' "$WORK/run.out" || true)" -ge 4 ] && break
  sleep 0.1
done
kill -TERM "$deploy"
rc=0
wait "$deploy" || rc=$?
elapsed=$(awk -v s="$start" -v e="$(date +%s.%N)" 'BEGIN { print e - s }')
cat "$WORK/run.out"
[ "$rc" -eq 0 ] || fail "ips-deploy run exited with status $rc after SIGTERM"
grep -q "^\[flaky\] hello from $(basename "$WORK") flaky$" "$WORK/run.out" ||
  fail "the environment or working directory did not reach the process"
grep -q '^\[stubborn\] ready$' "$WORK/run.out" || fail "no [stubborn] output"
for delay in 0.2 0.4 0.8; do
  grep -q "flaky exited with status 3 after .*; restarting in $delay s" "$WORK/run.out" ||
    fail "no restart after $delay s"
done
grep -q '^\[ips-deploy\] stubborn did not stop in time: SIGKILL$' "$WORK/run.out" ||
  fail "stubborn was not killed after its stop timeout"
grep -q '^\[ips-deploy\] twr stopped (status 0)$' "$WORK/run.out" || fail "twr did not stop on SIGINT"
# Started after flaky (after: [flaky]) and stopped before it.
awk '/started flaky/ && !f { f = NR } /started stubborn/ && !s { s = NR } END { exit !(f && s && f < s) }' \
  "$WORK/run.out" || fail "stubborn started before flaky"
# 4 flaky runs take 0.6 s + 0.2 + 0.4 + 0.8 s of back-off; the stop 0.5 s more (stubborn). The
# delays themselves are checked in the messages above; the upper bound only catches a hang (a
# loaded machine can take several seconds more).
awk -v t="$elapsed" 'BEGIN { exit !(t >= 2.0 && t < 30) }' || fail "run took $elapsed s"
echo "run: restarts at 0.2, 0.4, 0.8 s, SIGKILL after the stop timeout, status 0 ($elapsed s)"

# --- 4: run ends when everything has ended ---------------------------------------------------
cat >"$WORK/once.yaml" <<'EOF'
name: once
lcm_url: "memq://"
hosts:
  - name: pc
    processes:
      - {name: one, command: /bin/true, restart: on-failure}
      - {name: two, command: /bin/sh, args: [-c, "exit 0"], restart: "no"}
EOF
timeout 60 "$D" run "$WORK/once.yaml" --host pc >"$WORK/once.out" 2>&1 || fail "run once: $(cat "$WORK/once.out")"
grep -q 'every process has ended' "$WORK/once.out" || fail "run once: $(cat "$WORK/once.out")"
sed 's|command: /bin/true, restart: on-failure|command: /bin/false, restart: "no"|' "$WORK/once.yaml" >"$WORK/fails.yaml"
run_to_end() {  # run_to_end NAME: ips-deploy run $WORK/NAME.yaml to its end; its status in rc
  set +e
  timeout 60 "$D" run "$WORK/$1.yaml" --host pc >"$WORK/$1.out" 2>&1
  rc=$?
  set -e
}
run_to_end fails
[ "$rc" -eq 1 ] || fail "a process that failed for good: status $rc (expected 1): $(cat "$WORK/fails.out")"
grep -q 'one exited with status 1 after .*; not restarted (restart: no)' "$WORK/fails.out" ||
  fail "$(cat "$WORK/fails.out")"
# A program that cannot be executed (its interpreter is missing): said, and a failure.
printf '#!/no/such/interpreter\n' >"$WORK/broken.sh"
chmod +x "$WORK/broken.sh"
printf 'name: broken\nlcm_url: "memq://"\nhosts:\n  - name: pc\n    processes:\n      - {name: b, command: %s, restart: "no"}\n' \
  "$WORK/broken.sh" >"$WORK/broken.yaml"
run_to_end broken
[ "$rc" -eq 1 ] || fail "a program that cannot run: status $rc (expected 1): $(cat "$WORK/broken.out")"
grep -q "^\[ips-deploy\] b: cannot run $WORK/broken.sh: No such file or directory$" "$WORK/broken.out" ||
  fail "$(cat "$WORK/broken.out")"

# --- 5: nothing is left behind ---------------------------------------------------------------
# SIGHUP (the terminal closed) stops everything as SIGTERM does; a SIGKILLed ips-deploy takes its
# processes with it (PR_SET_PDEATHSIG: SIGTERM from the kernel).
cat >"$WORK/left.yaml" <<EOF
name: left
lcm_url: "memq://"
hosts:
  - name: pc
    processes:
      - {name: twr, command: ips-uwb-twr}
      - {name: loop, command: /bin/sh, args: [-c, "while true; do sleep 0.1; done"]}
EOF
started_pids() {  # the pids ips-deploy started, from its output
  sed -n 's/^\[ips-deploy\] started [a-z]* (pid \([0-9]*\)).*/\1/p' "$1"
}
running() {  # running PID...: true while one of them is alive and not a zombie
  local p
  for p in "$@"; do
    [ -r "/proc/$p/stat" ] && [ "$(awk '{print $3}' "/proc/$p/stat" 2>/dev/null)" != Z ] && return 0
  done
  return 1
}
# twr_ready PID...: the one running ips-uwb-twr has blocked SIGINT for its signalfd (its node is
# set up: a SIGINT now stops it cleanly).
twr_ready() {
  local p
  for p in "$@"; do
    [ "$(cat "/proc/$p/comm" 2>/dev/null)" = ips-uwb-twr ] || continue
    local blk
    blk=$(awk '/^SigBlk:/ { print $2 }' "/proc/$p/status" 2>/dev/null)
    [ -n "$blk" ] && (( (16#$blk >> 1) & 1 )) && return 0
  done
  return 1
}
for how in HUP KILL; do
  out="$WORK/left-$how.out"
  "$D" run "$WORK/left.yaml" --host pc --bin-dir "$BIN" >"$out" 2>&1 & deploy=$!
  for _ in $(seq 600); do  # at most 60 s
    [ "$(started_pids "$out" | wc -l)" -eq 2 ] && break
    sleep 0.1
  done
  kids=$(started_pids "$out" | tr '\n' ' ')
  [ "$(echo $kids | wc -w)" -eq 2 ] || fail "SIG$how: not started: $(cat "$out")"
  for _ in $(seq 600); do
    # shellcheck disable=SC2086
    twr_ready $kids && break
    sleep 0.1
  done
  # shellcheck disable=SC2086
  twr_ready $kids || fail "SIG$how: ips-uwb-twr did not set up within 60 s: $(cat "$out")"
  kill -"$how" "$deploy"
  rc=0
  wait "$deploy" || rc=$?
  for _ in $(seq 600); do  # at most 60 s
    running $kids || break
    sleep 0.1
  done
  # shellcheck disable=SC2086
  if running $kids; then
    ps -o pid,stat,cmd -p "$(echo $kids | tr ' ' ,)" || true
    kill -KILL $kids 2>/dev/null || true
    fail "SIG$how to ips-deploy left its processes running"
  fi
  if [ "$how" = HUP ]; then
    [ "$rc" -eq 0 ] || fail "ips-deploy exited with status $rc after SIGHUP: $(cat "$out")"
    grep -q '^\[ips-deploy\] twr stopped (status 0)$' "$out" || fail "SIGHUP: $(cat "$out")"
  else
    [ "$rc" -eq 137 ] || fail "ips-deploy exited with status $rc after SIGKILL"
  fi
  echo "SIG$how to ips-deploy: its processes ($kids) are gone"
done

echo "deploy_cli: ok"
