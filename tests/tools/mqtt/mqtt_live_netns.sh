#!/usr/bin/env bash
# ips-mqtt against a real broker (Debian's mosquitto) on loopback in a private network namespace,
# with real LCM multicast (issue 24 item 5). ips-site publishes config/sites/lab.yaml (site 'lab');
# mqtt_bus_publish puts poses, zone events, alerts and a HEALTH on the bus; mosquitto_sub (a
# persistent QoS 1 session, so that it loses nothing across a broker restart) writes what the
# broker delivers. It checks that:
#  (a) ips-mqtt takes the site's name from SITE: its HEALTH reaches ips/lab/health/ips-mqtt with
#      the note saying so;
#  (b) every message comes out on its topic with the values published, field by field (poses of
#      two channels, a tag id with '/' sanitised in its topic, zone events, alerts, HEALTH);
#  (c) --max-pose-hz 5: 100 poses in 1 s of one tag give about 5 messages, the last pose among
#      them, and the others are counted as merged in HEALTH's note (sent + merged = 100);
#  (d) with a password: a broker that refuses anonymous clients takes the bridge given
#      --password-file (with --retain-health: a client subscribing later gets the last HEALTH
#      retained), and refuses one given a wrong IPS_MQTT_PASSWORD: that one is degraded in
#      HEALTH, "broker ...:1884 unreachable since ...", the broker's refusal in words;
#  (e) the broker killed mid-run while poses flow at 50 Hz: HEALTH degraded with "unreachable
#      since ...: N messages not sent" within seconds, OK again within seconds of the restart,
#      and the poses lost are only those published during the outage, and no more than the
#      bridge counted as not sent.
# Every wait is for a message or a state, with a generous bound. Exit 77 (skipped) without
# mosquitto and mosquitto-clients, or when no network namespace can be made here.
set -euo pipefail
BIN=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
MOSQUITTO=$(PATH="$PATH:/usr/sbin:/sbin" command -v mosquitto || true)
for tool in "$MOSQUITTO" "$(command -v mosquitto_sub || true)" "$(command -v mosquitto_pub || true)" \
            "$(PATH="$PATH:/usr/sbin" command -v mosquitto_passwd || true)"; do
  if [ -z "$tool" ]; then
    echo "SKIP: mosquitto or mosquitto-clients missing (scripts/install-deps all installs them)"
    exit 77
  fi
done
source "$ROOT/tests/integration/live_test_lib.sh"

LOG="$WORK/bus.lcm"
SUB="$WORK/sub.txt"
check() { python3 "$HERE/mqtt_check.py" "$@"; }
health() { python3 "$ROOT/tests/drivers/health_wait.py" "$LOG" --source ips-mqtt "$@"; }
pub() { "$BIN/mqtt_bus_publish" "$@"; }
now() { date +%s%6N; }
# broker NAME PORT [EXTRA CONFIG LINES]: a mosquitto on 127.0.0.1:PORT, persistent (its sessions
# survive a restart), running as us (as root it would switch to the mosquitto user).
broker_conf() {
  mkdir -p "$WORK/$1"
  printf '%s\n' "listener $2 127.0.0.1" "persistence true" "persistence_location $WORK/$1/" \
    "queue_qos0_messages true" "user $(id -un)" "${@:3}" >"$WORK/$1.conf"
}
start_broker() {  # NAME PORT [mosquitto_pub credentials]: starts it, waits until it takes a client
  "$MOSQUITTO" -c "$WORK/$1.conf" >>"$WORK/$1.log" 2>&1 &
  broker_pid=$!
  pids+=($broker_pid)
  local deadline=$((SECONDS + 30))
  until mosquitto_pub -h 127.0.0.1 -p "$2" "${@:3}" -t probe -n 2>/dev/null; do
    [ "$SECONDS" -lt "$deadline" ] || fail "mosquitto on port $2 not up within 30 s: $(cat "$WORK/$1.log")"
    kill -0 "$broker_pid" || fail "mosquitto on port $2 exited: $(cat "$WORK/$1.log")"
    sleep 0.1
  done
}
# sub_ready FILE PORT TOPIC [credentials]: publishes probes on TOPIC until mosquitto_sub wrote one.
sub_ready() {
  local deadline=$((SECONDS + 30))
  until grep -qs "^$3 " "$1"; do
    [ "$SECONDS" -lt "$deadline" ] || fail "mosquitto_sub on port $2 received no probe in 30 s"
    mosquitto_pub -h 127.0.0.1 -p "$2" "${@:4}" -t "$3" -m '{}' || true
    sleep 0.2
  done
}

"$BIN/ips-bus-check" --timeout 30 || fail "multicast does not loop back inside the namespace"
broker_conf broker 1883 "allow_anonymous true"
start_broker broker 1883
main_broker=$broker_pid
mosquitto_sub -h 127.0.0.1 -p 1883 -c -i ips-test-sub -q 1 -t 'ips/#' -t 'rl/#' -v >"$SUB" \
  2>"$WORK/sub.err" &
pids+=($!)
sub_ready "$SUB" 1883 ips/probe
lcm-logger -q -f "$LOG" & logger=$!; pids+=($logger)
logger_sync "$LOG"
"$BIN/ips-site" "$ROOT/config/sites/lab.yaml" --period 1 --log-level warn & site=$!; pids+=($site)
MQTT=("$BIN/ips-mqtt" --max-pose-hz 0 --qos 1 --pose-channel POSE_FUSED,POSE_UWB
      --reconnect-min 0.2 --reconnect-max 1)
"${MQTT[@]}" 2>"$WORK/mqtt.err" & mqtt=$!; pids+=($mqtt)
"$BIN/ips-bus-check" --wait-for ips-site ips-mqtt --timeout 60 || fail "ips-mqtt did not come up"

echo "--- (a) the site's name from SITE"
check wait "$SUB" ips/lab/health/ips-mqtt --field pid=$mqtt --field state='"ok"' \
  --contains "note=topics under ips/lab (site 'lab' from SITE)" --timeout 60
grep -q "ips-mqtt: broker 127.0.0.1:1883: connected$" "$WORK/mqtt.err" || fail "no 'connected' line"

echo "--- (b) every message on its topic, as published"
pub pose POSE_FUSED T1 0 5 0
pub pose POSE_UWB T/2 10 2 0
pub zone T1 Z1 1 1
pub zone T1 any 2 2
pub alert 1 1
pub alert 2 2
pub health fake+1 1
check wait "$SUB" ips/lab/tag/T1/pose --count 5 --timeout 30
check wait "$SUB" ips/lab/tag/T_2/pose --count 2 --timeout 30
check wait "$SUB" ips/lab/tag/T1/zone --count 2 --timeout 30
check wait "$SUB" ips/lab/alert --count 2 --timeout 30
check wait "$SUB" ips/lab/health/fake_1 --timeout 30
check static "$SUB"

echo "--- (c) --max-pose-hz 5"
"$BIN/ips-mqtt" --max-pose-hz 5 --topic-prefix rl --site-name rl-site --client-id ips-mqtt-rl \
  2>"$WORK/rl.err" & rl=$!; pids+=($rl)
check wait "$SUB" rl/rl-site/health/ips-mqtt --field pid=$rl --timeout 60
# 100 poses at 100 Hz: 1 s, or longer on a loaded machine; the bound on what the bridge sends is
# taken over the time they really took.
published=$(pub pose POSE_FUSED T9 100 100 100)
echo "$published"
seconds=$(echo "$published" | sed -nE 's/^published 100 poses in ([0-9.]+) s from [0-9]+$/\1/p')
[ -n "$seconds" ] || fail "mqtt_bus_publish said: $published"
check rate "$SUB" --topic rl/rl-site/tag/T9/pose --health-topic rl/rl-site/health/ips-mqtt \
  --pid $rl --count 100 --last 199 --max-hz 5 --seconds "$seconds"
check wait "$SUB" ips/lab/tag/T9/pose --count 100 --timeout 30  # the other bridge: every one
stop $rl "ips-mqtt (rate-limited)"
grep -q "messages sent, 0 not sent (broker away), [0-9]* poses merged by the rate limit" \
  "$WORK/rl.err" || fail "the rate-limited bridge's last line: $(tail -1 "$WORK/rl.err")"

echo "--- (d) a broker with passwords"
printf 'ips-secret\n' >"$WORK/password"
touch "$WORK/passwd"
mosquitto_passwd -b "$WORK/passwd" ips ips-secret
chmod 600 "$WORK/passwd"
broker_conf auth 1884 "allow_anonymous false" "password_file $WORK/passwd"
start_broker auth 1884 -u ips -P ips-secret
auth_broker=$broker_pid
mosquitto_sub -h 127.0.0.1 -p 1884 -u ips -P ips-secret -t 'pw/#' -v >"$WORK/auth.txt" \
  2>"$WORK/auth_sub.err" &
pids+=($!)
sub_ready "$WORK/auth.txt" 1884 pw/probe -u ips -P ips-secret
t_auth=$(now)
"$BIN/ips-mqtt" --port 1884 --username ips --password-file "$WORK/password" --topic-prefix pw \
  --client-id ips-mqtt-pw --retain-health 2>"$WORK/pw.err" & pw=$!; pids+=($pw)
IPS_MQTT_PASSWORD=wrong "$BIN/ips-mqtt" --port 1884 --username ips --topic-prefix pw \
  --client-id ips-mqtt-wrong 2>"$WORK/wrong.err" & wrong=$!; pids+=($wrong)
check wait "$WORK/auth.txt" pw/lab/health/ips-mqtt --field pid=$pw --timeout 60
# --retain-health: once the broker had one, a client that subscribes gets the last report at
# once, flagged retained.
check wait "$WORK/auth.txt" pw/lab/health/ips-site --timeout 30
mosquitto_sub -h 127.0.0.1 -p 1884 -u ips -P ips-secret -t pw/lab/health/ips-site --retained-only \
  -C 1 -W 30 -v >"$WORK/retained.txt" || fail "(d) no retained HEALTH of ips-site within 30 s"
grep -q '^pw/lab/health/ips-site {.*"source":"ips-site"' "$WORK/retained.txt" ||
  fail "(d) retained: $(cat "$WORK/retained.txt")"
health --state 1 --after "$t_auth" --timeout 60 \
  --error "broker 127.0.0.1:1884 unreachable since" || fail "(d) the wrong password not said"
grep -q "refused the connection: Connection Refused: not authorised" "$WORK/wrong.err" ||
  fail "(d) no refusal in words: $(cat "$WORK/wrong.err")"
stop $pw "ips-mqtt (password)"
stop $wrong "ips-mqtt (wrong password)"
grep -q "ips-mqtt: 0 messages sent, [1-9][0-9]* not sent (broker away)" "$WORK/wrong.err" ||
  fail "(d) the wrong password's bridge sent something: $(tail -1 "$WORK/wrong.err")"
stop $auth_broker mosquitto TERM

echo "--- (e) the broker killed mid-run"
"$BIN/mqtt_bus_publish" pose POSE_FUSED T5 1000 1000 50 >"$WORK/flow.out" & flow=$!; pids+=($flow)
check wait "$SUB" ips/lab/tag/T5/pose --count 100 --timeout 60
t_kill=$(now)
kill -TERM "$main_broker"
wait "$main_broker" || true
forget "$main_broker"
health --state 1 --after "$t_kill" --health 2 --timeout 30 \
  --error "broker 127.0.0.1:1883 unreachable since" || fail "(e) not degraded while the broker is away"
t_restart=$(now)
start_broker broker 1883
health --state 0 --after "$t_restart" --timeout 60 || fail "(e) not OK again after the restart"
t_ok=$(now)
grep -q "connected again after" "$WORK/mqtt.err" || fail "(e) no 'connected again' line"
wait $flow || fail "mqtt_bus_publish"
forget $flow
check wait "$SUB" ips/lab/tag/T5/pose --field num_used=1999 --timeout 60
check outage "$SUB" --topic ips/lab/tag/T5/pose --first 1000 --count 1000 >"$WORK/outage.txt"
head -1 "$WORK/outage.txt"
# The poses lost were published between the kill (less 0.2 s: on their way then) and the HEALTH
# that said OK again; every pose outside that window arrived.
python3 - "$WORK/outage.txt" "$WORK/flow.out" "$t_kill" "$t_ok" "$LOG" "$mqtt" <<'PY' || fail "(e) the poses lost"
import json, sys
from lcm_log import events
from lcm_messages import health
missing = json.loads(open(sys.argv[1]).read().splitlines()[-1])
start = int(open(sys.argv[2]).read().split()[-1])
t_kill, t_ok = int(sys.argv[3]), int(sys.argv[4])
published = lambda n: start + (n - 1000) * 20000  # 50 Hz from the first pose's wall time
window = [n for n in range(1000, 2000) if t_kill - 200000 <= published(n) <= t_ok]
outside = [n for n in missing if n not in window]
hs = [h for h in (health(d) for c, _, d in events(sys.argv[5])[0] if c == 'HEALTH')
      if h['pid'] == int(sys.argv[6])]
degraded = [h for h in hs if h['state'] == 1]
print(f'outage: broker away {(t_ok - t_kill) / 1e6:.1f} s until HEALTH OK; {len(window)} poses '
      f'published meanwhile, {len(missing)} lost; ips-mqtt HEALTH: {len(degraded)} degraded, '
      f'drops {hs[-1]["drops"]}, last_error {hs[-1]["last_error"]!r}, state {hs[-1]["state"]}')
assert missing, 'nothing was lost while the broker was away?'
assert not outside, f'poses lost outside the outage: {outside}'
assert len(missing) <= len(window), (len(missing), len(window))
# Every pose lost was one the bridge knew it could not send (drops: those and HEALTH reports).
assert len(missing) <= hs[-1]['drops'], (len(missing), hs[-1]['drops'])
assert hs[-1]['state'] == 0 and 'messages not sent' in hs[-1]['last_error'], hs[-1]
PY
grep -E "connected again after" "$WORK/mqtt.err"

stop $mqtt ips-mqtt
stop $site ips-site
stop $logger lcm-logger
echo "--- ips-mqtt's log:"
cat "$WORK/mqtt.err"
echo "PASS"
