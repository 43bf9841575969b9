#!/usr/bin/env bash
# ips-deploy status against an `ips-deploy run` on this machine whose deployment file gives the
# host another machine's hostname (as config/deploy/lab-3-hosts.yaml does: lab-pc-2), with real
# processes and real LCM multicast in a private network namespace:
#  1. run warns once on stderr that this machine's hostname is not the file's, naming both;
#  2. status FILE lists the run's processes under their host, matched by the pids of the run's
#     run file (none MISSING, exit status 0), ips-deploy itself under that host too, and says so
#     in a note;
#  3. the same program started by hand on this machine is not taken for the run's process;
#  4. a process killed and restarted by the run shows with its new pid, and its exit is printed
#     once;
#  5. without the run file (another XDG_RUNTIME_DIR) the same processes are MISSING, status 1:
#     what the pids are for;
#  6. the run file is gone once the run has ended;
#  7. (first) the run's processes hold none of ips-deploy's sockets.
# Every wait is for a state, at most 60 s. Exit 77 (skipped) when no network namespace can be
# made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
source "$ROOT/tests/integration/live_test_lib.sh"
export XDG_RUNTIME_DIR="$WORK/xdg"
mkdir -m 700 "$XDG_RUNTIME_DIR"
HOSTNAME_HERE=$(hostname)
OTHER=lab-pc-2
[ "$HOSTNAME_HERE" != "$OTHER" ] || OTHER=lab-pc-9

cat >"$WORK/st.yaml" <<YAML
name: st
lcm_url: "$LCM_DEFAULT_URL"
bin_dir: $BIN
hosts:
  - name: compute
    hostname: $OTHER
    processes:
      - {name: twr, command: ips-uwb-twr, args: [--log-level, warn]}
      - {name: fuse, command: ips-fuse, args: [--log-level, warn]}
YAML

"$BIN/ips-deploy" run "$WORK/st.yaml" --host compute >"$WORK/run.out" 2>"$WORK/run.err" & deploy=$!
pids+=($deploy)

# status_json [VAR=VALUE...]: ips-deploy status --json (listening 2 s), whatever its exit status.
status_json() { env "$@" "$BIN/ips-deploy" status "$WORK/st.yaml" --wait 2 --json || true; }
# row PROCESS PROGRAM KEY < json: KEY of the row with that process name ("" for none) and program.
row() {
  python3 -c '
import json, sys
r = json.load(sys.stdin)
print(next((str(p[sys.argv[3]]) for p in r["processes"]
            if p["process"] == sys.argv[1] and p["program"] == sys.argv[2]), ""))' "$1" "$2" "$3"
}
started_pid() {  # started_pid NAME: the pid of NAME's latest start in the run's output
  sed -n "s/^\[ips-deploy\] started $1 (pid \([0-9]*\)).*/\1/p" "$WORK/run.out" | tail -1
}
# Both processes matched to their pids (each status listens 2 s: at most 60 s).
both_up() {
  [ "$(echo "$1" | row twr ips-uwb-twr pid)" = "$(started_pid twr)" ] &&
    [ "$(echo "$1" | row fuse ips-fuse pid)" = "$(started_pid fuse)" ]
}
s=
for _ in $(seq 30); do
  s=$(status_json)
  both_up "$s" && break
done
both_up "$s" || fail "status did not match the run's processes: $s; run: $(cat "$WORK/run.out")"

# The run's children hold none of ips-deploy's sockets (liblcm opens them without close-on-exec:
# a child holding ips-deploy's LCM socket counted its drops as its own).
sockets_of() { find "/proc/$1/fd" -maxdepth 1 -lname 'socket:*' -printf '%l\n' 2>/dev/null | sort; }
[ -n "$(sockets_of "$deploy")" ] || fail "ips-deploy has no socket to compare with"
for name in twr fuse; do
  shared=$(comm -12 <(sockets_of "$deploy") <(sockets_of "$(started_pid $name)"))
  [ -z "$shared" ] || fail "$name holds ips-deploy's sockets: $shared"
done
echo "run: its processes hold none of ips-deploy's $(sockets_of "$deploy" | wc -l) sockets"

# 1: the warning, once, naming both hostnames.
[ "$(grep -c 'warning: ' "$WORK/run.err")" -eq 1 ] || fail "warnings: $(cat "$WORK/run.err")"
grep -qxF "ips-deploy: warning: this machine's hostname is '$HOSTNAME_HERE', not '$OTHER' (host compute's in $WORK/st.yaml); HEALTH will say '$HOSTNAME_HERE'" \
  "$WORK/run.err" || fail "hostname warning: $(cat "$WORK/run.err")"
echo "run: warned that the hostname is $HOSTNAME_HERE, not $OTHER"

# 2: the table, its exit status and the note.
set +e
"$BIN/ips-deploy" status "$WORK/st.yaml" --wait 2 >"$WORK/status.txt"
rc=$?
set -e
cat "$WORK/status.txt"
[ "$rc" -eq 0 ] || fail "status exited with $rc"
grep -q '^2 of 2 expected processes heard$' "$WORK/status.txt" || fail "not 2 of 2"
grep -qxF "host compute: run on this machine by ips-deploy (pid $deploy) under hostname '$HOSTNAME_HERE' (the file says '$OTHER'); its processes matched by pid" \
  "$WORK/status.txt" || fail "no note on the match"
s=$(status_json)
[ "$(echo "$s" | row '' ips-deploy host)" = compute ] || fail "ips-deploy not under compute: $s"
[ "$(echo "$s" | row '' ips-deploy pid)" = "$deploy" ] || fail "ips-deploy's pid: $s"

# 3: an ips-uwb-twr started by hand here is listed apart, under this machine's hostname.
"$BIN/ips-uwb-twr" --log-level warn & hand=$!
pids+=($hand)
for _ in $(seq 30); do
  s=$(status_json)
  [ "$(echo "$s" | row '' ips-uwb-twr pid)" = "$hand" ] && break
done
[ "$(echo "$s" | row '' ips-uwb-twr pid)" = "$hand" ] || fail "the hand-started one: $s"
[ "$(echo "$s" | row '' ips-uwb-twr host)" = "$HOSTNAME_HERE" ] || fail "the hand-started one's host: $s"
[ "$(echo "$s" | row twr ips-uwb-twr pid)" = "$(started_pid twr)" ] || fail "twr taken for another: $s"
stop "$hand" ips-uwb-twr
echo "status: the run's twr (pid $(started_pid twr)) and the hand-started one (pid $hand) apart"

# 4: twr killed; the run restarts it; status follows the new pid.
old=$(started_pid twr)
kill -KILL "$old"
for _ in $(seq 600); do  # at most 60 s
  [ "$(started_pid twr)" != "$old" ] && break
  sleep 0.1
done
new=$(started_pid twr)
[ "$new" != "$old" ] || fail "twr was not restarted: $(cat "$WORK/run.out")"
for _ in $(seq 30); do
  s=$(status_json)
  [ "$(echo "$s" | row twr ips-uwb-twr pid)" = "$new" ] && break
done
[ "$(echo "$s" | row twr ips-uwb-twr pid)" = "$new" ] || fail "status after the restart: $s"
# The exit is printed once (on stdout), not again on stderr.
[ "$(cat "$WORK/run.out" "$WORK/run.err" | grep -c 'twr exited with signal 9 (SIGKILL)')" -eq 1 ] ||
  fail "the exit is not printed exactly once: $(cat "$WORK/run.out" "$WORK/run.err")"
echo "status: twr killed (pid $old), restarted as pid $new"

# 5: no run file, no match: the file's hostname is not this machine's.
mkdir -m 700 "$WORK/xdg-empty"
s=$(status_json XDG_RUNTIME_DIR="$WORK/xdg-empty")
[ "$(echo "$s" | row twr ips-uwb-twr state)" = MISSING ] || fail "without the run file: $s"
[ "$(echo "$s" | python3 -c 'import json, sys; print(json.load(sys.stdin)["missing"])')" = 2 ] ||
  fail "without the run file: $s"
set +e
XDG_RUNTIME_DIR="$WORK/xdg-empty" "$BIN/ips-deploy" status "$WORK/st.yaml" --wait 1 >/dev/null
rc=$?
set -e
[ "$rc" -eq 1 ] || fail "without the run file: status $rc (expected 1)"
echo "status without the run file: both MISSING, status 1"

# 6: the run ends; its file goes.
[ -f "$XDG_RUNTIME_DIR/ips-deploy/st-compute-$deploy.run" ] || fail "no run file"
stop "$deploy" ips-deploy
[ -z "$(ls -A "$XDG_RUNTIME_DIR/ips-deploy")" ] || fail "left: $(ls -A "$XDG_RUNTIME_DIR/ips-deploy")"
echo "deploy_status_netns: ok"
