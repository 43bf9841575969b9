# Sourced by the live integration tests, which run real processes over real LCM multicast:
#   source "$ROOT/tests/integration/live_test_lib.sh"
# Re-runs the calling script (with its arguments) inside a private network namespace whose
# loopback carries multicast (scripts/netns-run; exit 77, a skip, when none can be made here).
# Then gives it:
#   WORK            a scratch directory, removed at exit
#   pids+=($!)      background processes, killed at exit
#   forget PID      a reaped process, so that the cleanup never signals a reused pid
#   stop PID NAME [SIGNAL]  SIGINT (or SIGNAL) and wait; fails unless it exits with status 0
#   fail MESSAGE    "FAIL: MESSAGE" on stderr, exit 1
#   logger_sync FILE    publishes a probe (ips-bus-check, channel IPS_BUS_CHECK_<pid>) and waits
#                   until the lcm-logger writing FILE has recorded it: the logger is subscribed,
#                   and has recorded (or lost) everything published before (at most 60 s;
#                   runs $BIN/ips-bus-check)
# and exports LCM_DEFAULT_URL (the namespace's bus) and PYTHONPATH (tests/integration: lcm_log.py).
# Waiting for a message: `ips-bus-check --wait-for NAME` (a process is up), logger_sync (a
# logger is up, or has caught up), log_wait.py (a log holds an event: an estimator has caught
# up with the simulator); never a fixed sleep, which a loaded machine can overrun.
IPS_TEST_LIB_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [ "${IPS_IN_NETNS:-}" != "1" ]; then
  IPS_IN_NETNS=1 exec "$IPS_TEST_LIB_DIR/../../scripts/netns-run" "$0" "$@"
fi
WORK=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  rm -rf "$WORK"
}
trap cleanup EXIT
# A 4 MiB receive buffer (capped by net.core.rmem_max): the sanitizer builds of the processes
# under test can stall for a fraction of a second on a loaded machine, and at 1000 and more
# datagrams a second the default 208 KiB overflows and drops some.
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
export PYTHONPATH="$IPS_TEST_LIB_DIR${PYTHONPATH:+:$PYTHONPATH}"
fail() { echo "FAIL: $*" >&2; exit 1; }
forget() {
  local kept=() p
  for p in "${pids[@]}"; do [ "$p" = "$1" ] || kept+=("$p"); done
  pids=("${kept[@]}")
}
probes_in() { { grep -ao 'IPS_BUS_CHECK_' "$1" 2>/dev/null || true; } | wc -l; }
logger_sync() {
  local before deadline=$((SECONDS + 60)) i
  before=$(probes_in "$1")
  while [ "$SECONDS" -lt "$deadline" ]; do
    # A probe sent before the logger subscribed is not recorded: send again after 1 s.
    "${BIN:?}/ips-bus-check" --timeout 30 >/dev/null || fail "multicast does not loop back"
    for i in $(seq 20); do
      [ "$(probes_in "$1")" -gt "$before" ] && return 0
      sleep 0.05  # lcm-logger flushes every 100 ms
    done
  done
  fail "the lcm-logger writing $1 recorded no probe within 60 s"
}
stop() {
  kill -"${3:-INT}" "$1"
  local rc=0
  wait "$1" || rc=$?
  forget "$1"
  [ "$rc" -eq 0 ] || fail "$2 exited with status $rc after SIG${3:-INT} (expected 0)"
}
