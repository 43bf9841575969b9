# Sourced by tests/viewer/view_console.sh and scripts/bench-view: ips-view and chromedriver
# started on free ports, each waited for by its first line (at most 60 s, never a fixed sleep).
# The caller defines BIN (ips-view's folder), the array pids (what to kill at exit) and fail().

# view_start ERR ARGS...: ips-view ARGS on a free port, its stderr in ERR; sets $url.
view_start() {
  local err=$1
  shift
  : >"$err"
  "$BIN/ips-view" "$@" --port 0 --log-level warn 2>"$err" & pids+=($!)
  local deadline=$((SECONDS + 60))
  until grep -q '^ips-view: serving http://127.0.0.1:[0-9]*/' "$err"; do
    [ "$SECONDS" -lt "$deadline" ] || fail "ips-view did not start: $(cat "$err")"
    sleep 0.1
  done
  url=$(sed -n 's|^ips-view: serving \(http://127.0.0.1:[0-9]*/\).*|\1|p' "$err" | head -1)
}

# chromedriver_start LOG: chromedriver on a free port, its output in LOG; sets $webdriver.
chromedriver_start() {
  local log=$1
  : >"$log"
  chromedriver --port=0 >"$log" 2>&1 & pids+=($!)
  local deadline=$((SECONDS + 60))
  until grep -Eq 'ChromeDriver was started successfully on port [0-9]+' "$log"; do
    [ "$SECONDS" -lt "$deadline" ] || fail "chromedriver did not start: $(cat "$log")"
    sleep 0.1
  done
  webdriver="http://127.0.0.1:$(grep -Eo 'started successfully on port [0-9]+' "$log" | grep -Eo '[0-9]+$')"
}
