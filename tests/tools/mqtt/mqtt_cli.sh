#!/usr/bin/env bash
# ips-mqtt's command line (issue 24 item 5): --help with its example and every flag; each bad
# option one line "ips-mqtt: error: ..." and status 2, before anything is opened; a broker that
# is not on this machine without TLS: one warning line at start.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"
M="$BIN/ips-mqtt"

if run 0 "$M" --help; then
  for want in "Example" "mosquitto_sub -t 'ips/#' -v" "--pose-channel" "--max-pose-hz" "--qos" \
    "--host" "--password-file" "--cafile" "--tls-insecure" "--reconnect-max" "--topic-prefix"; do
    grep -qF -- "$want" "$WORK/out" && ok "--help has '$want'" || fail "--help lacks '$want'"
  done
  grep -q -- "--password " "$WORK/out" && fail "--help offers a password on the command line"
fi
printf 'secret\n' >"$WORK/password"
: >"$WORK/empty"
expect_saying 2 "The following argument was not expected: --bogus" "$M" --bogus
expect_saying 2 "--qos: Value 2 not in range 0 to 1" "$M" --qos 2
expect_saying 2 "--max-pose-hz: Value -1 not in range" "$M" --max-pose-hz -1
expect_saying 2 "--port: Value 0 not in range 1 to 65535" "$M" --port 0
expect_saying 2 "--keepalive: Value 2 not in range 5 to 65535" "$M" --keepalive 2
expect_saying 2 "--pose-channel: 'POSE-X' is not a channel name" "$M" --pose-channel POSE_FUSED,POSE-X
expect_saying 2 "--topic-prefix 'ips/+': holds the wildcard '+'" "$M" --topic-prefix 'ips/+'
expect_saying 2 "--topic-prefix 'ips//x': has an empty level" "$M" --topic-prefix 'ips//x'
expect_saying 2 "--topic-prefix '\$SYS': starts with '\$'" "$M" --topic-prefix '$SYS'
expect_saying 2 "--site-name: empty" "$M" --site-name ''
expect_saying 2 "--host: empty" "$M" --host ''
expect_saying 2 "--reconnect-max: less than --reconnect-min" "$M" --reconnect-min 5 --reconnect-max 1
expect_saying 2 "--cert and --key go together" "$M" --cert "$WORK/password"
expect_saying 2 "--cert needs --cafile (TLS)" "$M" --cert "$WORK/password" --key "$WORK/password"
expect_saying 2 "--tls-insecure needs --cafile" "$M" --tls-insecure
expect_saying 2 "--cafile: $WORK/none.pem: cannot read: No such file or directory" "$M" \
  --cafile "$WORK/none.pem"
expect_saying 2 "--password-file needs --username" "$M" --password-file "$WORK/password"
expect_saying 2 "--password-file: $WORK/none: cannot read: No such file or directory" "$M" \
  --username ips --password-file "$WORK/none"
expect_saying 2 "--password-file: '$WORK/empty' holds no password on its first line" "$M" \
  --username ips --password-file "$WORK/empty"
# A broker elsewhere without TLS: the warning, then (here) the bus that cannot be opened.
WANT_LINES=2 expect 1 "^ips-mqtt: warning: --host 192.0.2.1 is not this machine and TLS is off \(--cafile\): positions and the password cross the network in clear$" \
  "$M" --host 192.0.2.1 --username ips --password-file "$WORK/password" --lcm-url 'bogus://x'
echo "$failures failure(s)"
[ "$failures" -eq 0 ]
