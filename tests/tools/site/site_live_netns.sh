#!/usr/bin/env bash
# ips-site live over real LCM multicast in a private network namespace (issue 23). ips-site
# publishes a copy of config/sites/lab.yaml every second; ips-uwb-twr runs without --site; ips-sim
# plays the lab (seed 1, 1x) with its own SITE renamed to SIM_SITE, which nobody reads, so the
# only site on the bus is ips-site's; the real lcm-logger records. It checks that:
#  (a) ips-uwb-twr takes ips-site's site and tracks the tag with it: POSE_UWB at the site's tag
#      height (1.2 m, the lab's tag is tracked in 2D);
#  (b) an edit written in place that moves anchor A2 by 0.1 m and sets the tag's height to 1.25 m
#      is on SITE within 15 s, and ips-uwb-twr takes it: its log says so, POSE_UWB at 1.25 m;
#  (c) a broken edit saved as editors do (a new file renamed over the old) leaves the previous
#      site on the bus (every SITE after it has A2 at 10.1), ips-site's HEALTH degraded with the
#      error and its file:line (also on its stderr), ips-uwb-twr not told anything new; the file
#      fixed, HEALTH is ok again;
#  (d) SIGHUP re-reads: with the file behind a symlink, an edit of the target is not a change in
#      the watched directory (SITE keeps the old site for two periods), and SIGHUP publishes it;
#      the process goes on and stops cleanly (status 0) on SIGINT.
# Every wait is for a message or a line, with a generous upper bound. Exit 77 (skipped) when no
# network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"

LOG="$WORK/bus.lcm"
SITE="$WORK/etc/lab.yaml"
bus() { python3 "$HERE/site_bus.py" "$@"; }
health() { python3 "$ROOT/tests/drivers/health_wait.py" "$LOG" --source ips-site "$@"; }
now() { date +%s%6N; }
# wait_lines FILE PATTERN N: until FILE has N lines matching PATTERN (grep -E), at most 60 s.
wait_lines() {
  local deadline=$((SECONDS + 60))
  while [ "$(grep -cE -- "$2" "$1" || true)" -lt "$3" ]; do
    [ "$SECONDS" -lt "$deadline" ] ||
      fail "$1: fewer than $3 lines matching '$2' within 60 s:$(echo; cat "$1")"
    sleep 0.1
  done
}
# lines FILE PATTERN N: FILE has exactly N lines matching PATTERN.
lines() {
  local n
  n=$(grep -cE -- "$2" "$1" || true)
  [ "$n" -eq "$3" ] || fail "$1: $n lines matching '$2', expected $3:$(echo; cat "$1")"
}
# edit_in_place SED: rewrites the file the path leads to, same inode (IN_CLOSE_WRITE).
edit_in_place() {
  local text
  text=$(sed "$1" "$SITE")
  printf '%s\n' "$text" >"$SITE"
}
# save_by_rename SED: writes the edited text to a new file in the same directory and renames it
# over the site file, as editors save.
save_by_rename() {
  sed "$1" "$SITE" >"$WORK/etc/.lab.yaml.new"
  mv "$WORK/etc/.lab.yaml.new" "$SITE"
}
TWR_TOOK="ips-uwb-twr: site 'lab' from ips-site \([0-9]+ anchors\)"
SITE_IS="site 'lab' \([0-9]+ anchors, 1 tags\)"

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
mkdir -p "$WORK/etc" "$WORK/store"
cp "$ROOT/config/sites/lab.yaml" "$SITE"
# The floor plan beside each copy of the site file (its path is relative to the file).
cp "$ROOT/config/sites/lab-plan.svg" "$WORK/etc/" && cp "$ROOT/config/sites/lab-plan.svg" "$WORK/store/"
lcm-logger -q -f "$LOG" & logger=$!; pids+=($logger)
logger_sync "$LOG"
t0=$(now)
"$BIN/ips-site" "$SITE" --period 1 2>"$WORK/site.err" & site=$!; pids+=($site)
"$BIN/ips-uwb-twr" 2>"$WORK/twr.err" & twr=$!; pids+=($twr)
"$BIN/ips-bus-check" --wait-for ips-site ips-uwb-twr --timeout 60 ||
  fail "ips-site and ips-uwb-twr did not come up"
"$BIN/ips-sim" --scenario lab --seed 1 --duration 900 --channel SITE=SIM_SITE --log-level warn &
sim=$!; pids+=($sim)

echo "--- (a) the tracker takes ips-site's site"
bus site "$LOG" --after "$t0" --anchor A2 --x 10.0 --count 2 --timeout 60 || fail "(a) SITE"
bus poses "$LOG" --after "$t0" --z 1.2 --count 20 --timeout 90 || fail "(a) POSE_UWB"
lines "$WORK/twr.err" "$TWR_TOOK" 1
lines "$WORK/twr.err" "from ips-sim" 0

echo "--- (b) an anchor moved: re-published, and the tracker takes it"
t_edit=$(now)
edit_in_place 's/position: \[10.0, 0.0, 2.4\]/position: [10.1, 0.0, 2.4]/; s/{id: T1, height_m: 1.2/{id: T1, height_m: 1.25/'
bus site "$LOG" --after "$t_edit" --anchor A2 --x 10.1 --count 1 --timeout 15 ||
  fail "(b) the edit was not on SITE within 15 s"
wait_lines "$WORK/twr.err" "$TWR_TOOK" 2
bus poses "$LOG" --after "$t_edit" --z 1.25 --count 20 --timeout 90 || fail "(b) POSE_UWB"
moved="\(changed\): $SITE_IS replaced: anchor A2 moved 0.10 m to \[10.1, 0, 2.4\]; tag T1 height_m 1.2 -> 1.25"
wait_lines "$WORK/site.err" "$moved" 1
lines "$WORK/site.err" "replaced:" 1
cp "$SITE" "$WORK/good.yaml"

echo "--- (c) a broken edit: the old site stays, HEALTH says why"
t_bad=$(now)
save_by_rename 's/position: \[10.0, 8.0, 2.4\]/position: [10.0, 8.0]/'
a3_line=$(grep -n "{id: A3," "$SITE" | cut -d: -f1)  # the line the loader names
error="$SITE:$a3_line: anchors\[2\].position: expected a list of 3 numbers"
health --state 1 --error "$SITE:$a3_line: anchors[2].position: expected a list of 3 numbers" \
  --after "$t_bad" --timeout 30 || fail "(c) ips-site's HEALTH is not degraded with the error"
wait_lines "$WORK/site.err" "not published, the previous site stays: $error" 1
t_degraded=$(now)
# Every SITE since the broken save, and three after ips-site said so, carry the previous site.
bus site "$LOG" --after "$t_bad" --anchor A2 --x 10.1 --count 3 --timeout 30 || fail "(c) SITE"
bus site "$LOG" --after "$t_degraded" --anchor A2 --x 10.1 --count 3 --timeout 30 || fail "(c) SITE"
lines "$WORK/twr.err" "$TWR_TOOK" 2
echo "fixed:"
t_fix=$(now)
cp "$WORK/good.yaml" "$WORK/etc/.lab.yaml.new"
mv "$WORK/etc/.lab.yaml.new" "$SITE"
health --state 0 --after "$t_fix" --timeout 30 || fail "(c) ips-site's HEALTH is not ok once fixed"
wait_lines "$WORK/site.err" "\(changed\): loads again, as the $SITE_IS already published" 1
bus site "$LOG" --after "$t_fix" --anchor A2 --x 10.1 --count 2 --timeout 30 || fail "(c) SITE"
lines "$WORK/twr.err" "$TWR_TOOK" 2  # the same text: nothing new for the tracker

echo "--- (d) SIGHUP re-reads"
# The file becomes a symlink to a copy elsewhere (A2 at 10.15 there): the rename is seen.
sed 's/position: \[10.1, 0.0, 2.4\]/position: [10.15, 0.0, 2.4]/' "$SITE" >"$WORK/store/lab.yaml"
t_link=$(now)
ln -s "$WORK/store/lab.yaml" "$WORK/etc/.lab.yaml.link"
mv -T "$WORK/etc/.lab.yaml.link" "$SITE"
bus site "$LOG" --after "$t_link" --anchor A2 --x 10.15 --count 1 --timeout 15 || fail "(d) link"
wait_lines "$WORK/twr.err" "$TWR_TOOK" 3
# The target edited where it is: no change in the watched directory, SITE stays for 2 periods.
t_target=$(now)
sed -i 's/position: \[10.15, 0.0, 2.4\]/position: [10.2, 0.0, 2.4]/; s/{id: T1, height_m: 1.25/{id: T1, height_m: 1.3/' \
  "$WORK/store/lab.yaml"
bus site "$LOG" --after "$t_target" --anchor A2 --x 10.15 --count 2 --timeout 30 || fail "(d) SITE"
t_hup=$(now)
kill -HUP "$site"
bus site "$LOG" --after "$t_hup" --anchor A2 --x 10.2 --count 1 --timeout 15 ||
  fail "(d) SIGHUP did not publish the edit within 15 s"
wait_lines "$WORK/site.err" "\(SIGHUP\): $SITE_IS replaced: anchor A2 moved 0.05 m to \[10.2, 0, 2.4\]; tag T1 height_m 1.25 -> 1.3" 1
wait_lines "$WORK/twr.err" "$TWR_TOOK" 4
bus poses "$LOG" --after "$t_hup" --z 1.3 --count 20 --timeout 90 || fail "(d) POSE_UWB"
kill -0 "$site" || fail "ips-site ended on SIGHUP"

stop $site ips-site
stop $twr ips-uwb-twr
stop $sim ips-sim
logger_sync "$LOG"
stop $logger lcm-logger
# ips-site's last HEALTH: one reading refused (the broken save), its error kept as last_error.
python3 - "$LOG" <<'PY' || fail "ips-site's last HEALTH"
import sys
from lcm_log import events
from lcm_messages import health
hs = [health(d) for c, _, d in events(sys.argv[1])[0] if c == 'HEALTH']
h = [h for h in hs if h['source'] == 'ips-site'][-1]
print(f"ips-site's last HEALTH: state {h['state']}, parse_errors {h['parse_errors']}, "
      f"msgs_out {h['msgs_out']}, last_error {h['last_error']!r}")
assert h['state'] == 0 and h['parse_errors'] == 1, h
assert 'anchors[2].position: expected a list of 3 numbers' in h['last_error'], h
PY
echo "--- ips-site's log:"
cat "$WORK/site.err"
echo "PASS"
