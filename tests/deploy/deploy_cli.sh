#!/usr/bin/env bash
# ips-deploy on one machine (LCM memq://, no network needed):
#  1. check and its errors (file:line: field: reason), a host that is not there, a program that
#     is not there;
#  2. systemd: the units written for the systemd version given or found here, refused over
#     existing files without --force, refused when a program cannot be found unless
#     --allow-missing, and accepted by `systemd-analyze verify` when it is installed: the units
#     for this machine's systemd without a single warning (no unknown key);
#  3. run: output prefixed with the process name, a failing process restarted with a doubling
#     back-off (0.2, 0.4, 0.8 s) and each exit printed once, a process that ignores SIGINT killed
#     after its stop timeout, SIGTERM stopping everything with status 0, environment and working
#     directory, the warning when this machine's hostname is not the host's;
#  4. run ends by itself, status 0, when every process has ended cleanly and none restarts; a
#     working_dir that is not here is an error naming it and --working-dir, which overrides it;
#  5. SIGHUP stops everything cleanly; a SIGKILLed ips-deploy leaves no process running.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/cli_test_lib.sh"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
D="$BIN/ips-deploy"
# The run files of `run` (tools/deploy/run_file.hpp) go here, not into the user's.
export XDG_RUNTIME_DIR="$WORK/xdg"
mkdir -m 700 "$XDG_RUNTIME_DIR"
HOSTNAME_HERE=$(hostname)

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
# For systemd 254: the exponential back-off keys, no retry units.
"$D" systemd "$WORK/d.yaml" --host pc --out "$WORK/units" --systemd-version 254 >"$WORK/units.txt"
grep -q "^wrote 4 units for host pc into $WORK/units, for systemd 254 (--systemd-version)$" "$WORK/units.txt" ||
  fail "systemd output: $(cat "$WORK/units.txt")"
ls "$WORK/units" | sort >"$WORK/units.list"
printf '%s\n' ips-bench-flaky.service ips-bench-stubborn.service ips-bench-twr.service \
  ips-bench.target | diff - "$WORK/units.list" || fail "unit files"
grep -qx "ExecStart=\"$BIN/ips-uwb-twr\"" "$WORK/units/ips-bench-twr.service" || fail "twr ExecStart"
grep -qx 'After=network-online.target ips-bench-flaky.service' "$WORK/units/ips-bench-stubborn.service" ||
  fail "stubborn's After="
grep -qx 'Environment="LCM_DEFAULT_URL=memq://"' "$WORK/units/ips-bench-twr.service" || fail "LCM URL"
grep -qx 'Restart=always' "$WORK/units/ips-bench-twr.service" || fail "Restart=always"
grep -qx 'RestartSec=0.2s' "$WORK/units/ips-bench-flaky.service" || fail "RestartSec"
grep -qx 'RestartSteps=2' "$WORK/units/ips-bench-flaky.service" || fail "RestartSteps (254)"
expect_error_saying "exists (--force to overwrite)" "$D" systemd "$WORK/d.yaml" --host pc --out "$WORK/units"
"$D" systemd "$WORK/d.yaml" --host pc --out "$WORK/units" --systemd-version 254 --force >/dev/null || fail "--force"
expect_error_saying "--systemd-version: Value 100 not in range" "$D" systemd "$WORK/d.yaml" --host pc \
  --out "$WORK/units-100" --systemd-version 100

# For systemd 252: not a key 252 does not know; a start limit and a retry unit instead.
"$D" systemd "$WORK/d.yaml" --host pc --out "$WORK/units-252" --systemd-version 252 >/dev/null
ls "$WORK/units-252" | sort >"$WORK/units-252.list"
printf '%s\n' ips-bench-flaky-retry.service ips-bench-flaky.service ips-bench-stubborn-retry.service \
  ips-bench-stubborn.service ips-bench-twr-retry.service ips-bench-twr.service ips-bench.target |
  diff - "$WORK/units-252.list" || fail "unit files for 252"
! grep '^RestartSteps=\|^RestartMaxDelaySec=' "$WORK"/units-252/* || fail "252: keys of 254"
# flaky: 0.2 s doubling to 0.8 s is 2 doublings: 3 starts in 0.2 + 0.4 + 0.8 s, then the retry.
grep -qx 'StartLimitIntervalSec=1.4s' "$WORK/units-252/ips-bench-flaky.service" || fail "252: interval"
grep -qx 'StartLimitBurst=3' "$WORK/units-252/ips-bench-flaky.service" || fail "252: burst"
grep -qx 'OnFailure=ips-bench-flaky-retry.service' "$WORK/units-252/ips-bench-flaky.service" ||
  fail "252: OnFailure="
grep -qx 'ExecStart=/bin/sleep 0.8' "$WORK/units-252/ips-bench-flaky-retry.service" || fail "252: retry"

# The version found here: systemctl --version's, else 252, said.
"$D" systemd "$WORK/d.yaml" --host pc --out "$WORK/units-here" >"$WORK/units-here.txt"
here=$(systemctl --version 2>/dev/null | sed -n '1s/^systemd \([0-9]*\).*/\1/p' || true)
if [ -n "$here" ]; then
  grep -q "for systemd $here (from systemctl --version)$" "$WORK/units-here.txt" ||
    fail "version found here: $(cat "$WORK/units-here.txt")"
else
  grep -q "for systemd 252 (the default: systemctl --version gave no version here; --systemd-version N to say)$" \
    "$WORK/units-here.txt" || fail "version by default: $(cat "$WORK/units-here.txt")"
fi
head -1 "$WORK/units-here/ips-bench-twr.service" | grep -q "for systemd ${here:-252}\. " || fail "header"
if command -v systemd-analyze >/dev/null && [ -n "$here" ]; then
  # The units for this machine's systemd: not one warning (an unknown key is one).
  set +e
  verify=$(cd "$WORK/units-here" && systemd-analyze verify ./*.service ./*.target 2>&1)
  rc=$?
  set -e
  [ "$rc" -eq 0 ] && [ -z "$(echo "$verify" | grep -v '^$' || true)" ] ||
    fail "systemd-analyze verify of the units for systemd $here (status $rc): $verify"
  echo "systemd-analyze verify: the units for systemd $here: no warning"
else
  echo "SKIP systemd-analyze verify: systemd-analyze or systemctl not installed here"
fi

# A program that cannot be found (bin_dir not here, not in systemd's search path): refused,
# naming it, unless --allow-missing.
sed "s|^working_dir: .*|bin_dir: $WORK/no-such-bin|; s|command: ips-uwb-twr|command: ips-no-such-program|" \
  "$WORK/d.yaml" >"$WORK/nobin.yaml"
expect_error_saying "1 of 3 programs not found: twr: ips-no-such-program (no directory $WORK/no-such-bin here, nor in systemd's search path); --bin-dir DIR to say where they are, or --allow-missing to write the units all the same" \
  "$D" systemd "$WORK/nobin.yaml" --host pc --out "$WORK/units-nobin"
[ ! -e "$WORK/units-nobin" ] || fail "units written although refused"
set +e
"$D" systemd "$WORK/nobin.yaml" --host pc --out "$WORK/units-nobin" --allow-missing >/dev/null 2>"$WORK/nobin.err"
rc=$?
set -e
[ "$rc" -eq 0 ] || fail "--allow-missing: status $rc: $(cat "$WORK/nobin.err")"
grep -qx "ips-deploy: warning: 1 of 3 programs not found: twr: ips-no-such-program (no directory $WORK/no-such-bin here, nor in systemd's search path); writing the units all the same (--allow-missing)" \
  "$WORK/nobin.err" || fail "--allow-missing: $(cat "$WORK/nobin.err")"
grep -qx 'ExecStart="ips-no-such-program"' "$WORK/units-nobin/ips-bench-twr.service" || fail "--allow-missing: ExecStart"

# The example in config/ is valid, and gives units for each of its hosts: refused where its
# bin_dir is not installed, written with --bin-dir where the programs are built.
"$D" check "$ROOT/config/deploy/lab-3-hosts.yaml" >/dev/null || fail "config/deploy/lab-3-hosts.yaml"
# The sharded example: one entry, three ips-fuse with --shard k/3 on three hosts, and the unit
# of one of them runs it so.
out=$("$D" check "$ROOT/config/deploy/lab-shards.yaml") || fail "config/deploy/lab-shards.yaml"
for k in 1 2 3; do
  echo "$out" | grep -qx "  fuse-$k: ips-fuse --shard $k/3  \[restart on-failure\]" ||
    fail "lab-shards.yaml: no fuse-$k with --shard $k/3: $out"
done
"$D" systemd "$ROOT/config/deploy/lab-shards.yaml" --host fuse-b --out "$WORK/units-shard" \
  --bin-dir "$BIN" --systemd-version 254 >/dev/null || fail "lab-shards.yaml: systemd --host fuse-b"
grep -qx "ExecStart=\"$BIN/ips-fuse\" \"--shard\" \"2/3\"" "$WORK/units-shard/ips-lab-fuse-2.service" ||
  fail "lab-shards.yaml: ExecStart of fuse-2: $(grep ExecStart "$WORK/units-shard/"*.service)"
if [ ! -d /usr/local/lib/ips-fusion/bin ]; then
  expect_error_saying "--allow-missing" "$D" systemd "$ROOT/config/deploy/lab-3-hosts.yaml" --host compute --out "$WORK/example-refused"
fi
for h in sensors compute recorder; do
  "$D" systemd "$ROOT/config/deploy/lab-3-hosts.yaml" --host "$h" --out "$WORK/example-$h" \
    --bin-dir "$BIN" --allow-missing --systemd-version 254 >/dev/null 2>&1
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
for delay in 0.2 0.4; do
  # Once: on stdout, and not again on stderr.
  [ "$(cat "$WORK/run.out" "$WORK/run.err" | grep -c "flaky exited with status 3 after .*; restarting in $delay s")" -eq 1 ] ||
    fail "the restart after $delay s is not printed exactly once: $(cat "$WORK/run.out" "$WORK/run.err")"
done
grep -q "flaky exited with status 3 after .*; restarting in 0.8 s" "$WORK/run.out" || fail "no restart after 0.8 s"
grep -q "exited" "$WORK/run.err" && fail "exits printed on stderr too: $(cat "$WORK/run.err")"
# The file's host pc has hostname pc: unless this machine is called so, one warning naming both.
if [ "$HOSTNAME_HERE" != pc ]; then
  [ "$(grep -c 'warning' "$WORK/run.err")" -eq 1 ] &&
    grep -qxF "ips-deploy: warning: this machine's hostname is '$HOSTNAME_HERE', not 'pc' (host pc's in $WORK/d.yaml); HEALTH will say '$HOSTNAME_HERE'" \
      "$WORK/run.err" || fail "hostname warning: $(cat "$WORK/run.err")"
fi
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
cat >"$WORK/once.yaml" <<EOF
name: once
lcm_url: "memq://"
hosts:
  - name: pc
    hostname: $HOSTNAME_HERE
    processes:
      - {name: one, command: /bin/true, restart: on-failure}
      - {name: two, command: /bin/sh, args: [-c, "exit 0"], restart: "no"}
EOF
timeout 60 "$D" run "$WORK/once.yaml" --host pc >"$WORK/once.out" 2>&1 || fail "run once: $(cat "$WORK/once.out")"
grep -q 'every process has ended' "$WORK/once.out" || fail "run once: $(cat "$WORK/once.out")"
grep -q 'warning' "$WORK/once.out" && fail "run once: a warning with the right hostname: $(cat "$WORK/once.out")"
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

# A working_dir that is not on this machine (the example's /var/lib/ips, say): an error naming
# the field and --working-dir, before anything starts; --working-dir DIR runs in DIR instead.
mkdir "$WORK/trial"
cat >"$WORK/wd.yaml" <<EOF
name: wd
lcm_url: "memq://"
working_dir: $WORK/no-such-dir
hosts:
  - name: pc
    processes:
      - {name: where, command: /bin/sh, args: [-c, "pwd -P"], restart: "no"}
EOF
expect_error_saying "$WORK/wd.yaml: working_dir '$WORK/no-such-dir' is not a directory on this machine: create it, or give --working-dir DIR to run the processes in DIR instead" \
  "$D" run "$WORK/wd.yaml" --host pc
expect_error_saying "--working-dir '$WORK/nope': not a directory" "$D" run "$WORK/wd.yaml" --host pc --working-dir "$WORK/nope"
(cd "$WORK" && timeout 60 "$D" run wd.yaml --host pc --working-dir trial >"$WORK/wd.out" 2>&1) ||
  fail "--working-dir: $(cat "$WORK/wd.out")"
grep -qx "\[where\] $(cd "$WORK/trial" && pwd -P)" "$WORK/wd.out" || fail "--working-dir: $(cat "$WORK/wd.out")"
if [ ! -d /var/lib/ips ]; then
  expect_error_saying "working_dir '/var/lib/ips' is not a directory on this machine: create it, or give --working-dir DIR" \
    "$D" run "$ROOT/config/deploy/lab-3-hosts.yaml" --host compute --bin-dir "$BIN"
fi
echo "run: working_dir missing said, --working-dir runs in the directory given"

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
