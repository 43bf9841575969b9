# Sourced by the HTTP abuse tests (tests/viewer/view_http_abuse_netns.sh,
# tests/drivers/phone_imu/phone_imu_http_abuse_netns.sh) after live_test_lib.sh:
#   abuse_start PID NAME ARGS...  starts `http_abuse.py attack ARGS... --ready --stats
#                   $WORK/abuse.json` beside the server PID (NAME in messages) and returns once
#                   the abuse is going (at most 120 s; fails if the generator or the server exits)
#   abuse_stop PID NAME  SIGTERM to the generator and its counts written; sets ended (utime, us);
#                   fails if the server PID is gone
#   abuse_check LOG ARGS...  http_abuse.py check of $WORK/abuse.json against the server's LOG
#                   (to $WORK/check.json)
#   peak_rss_kib PID     VmHWM of /proc/PID/status
ABUSE="$IPS_TEST_LIB_DIR/http_abuse.py"
abuse_start() {
  local server=$1 name=$2 i
  shift 2
  python3 "$ABUSE" attack "$@" --ready "$WORK/ready" --stats "$WORK/abuse.json" & abuse_pid=$!
  pids+=($abuse_pid)
  for ((i = 0; i < 2400; i++)); do
    [ -s "$WORK/ready" ] && break
    kill -0 $abuse_pid 2>/dev/null || fail "the abuse generator exited early"
    kill -0 "$server" 2>/dev/null || fail "$name died under abuse"
    sleep 0.05
  done
  [ -s "$WORK/ready" ] || fail "the abuse did not get going within 120 s"
  kill -0 "$server" 2>/dev/null || fail "$name died under abuse"
}
abuse_stop() {
  kill -TERM $abuse_pid
  wait $abuse_pid || fail "the abuse generator failed"
  forget $abuse_pid
  ended=$(date +%s%6N)
  kill -0 "$1" 2>/dev/null || fail "$2 died under abuse"
}
abuse_check() {
  local log=$1
  shift
  python3 "$ABUSE" check "$WORK/abuse.json" "$log" "$@" --out "$WORK/check.json" >/dev/null ||
    fail "the refusals counted: $(cat "$WORK/check.json" 2>/dev/null)"
}
peak_rss_kib() { awk '/^VmHWM:/ {print $2}' "/proc/$1/status"; }
