# Sourced by the command-line tests that count their failures and go on (unlike cli_test_lib.sh,
# whose fail exits at the first one):
#   fail MESSAGE                      prints "FAIL: MESSAGE" and adds one to $failures
#   ok MESSAGE                        prints "ok: MESSAGE"
#   run STATUS CMD ARGS...            runs CMD (timeout 60 s), stdout in $WORK/out, stderr in
#                                     $WORK/err; on an exit status other than STATUS: fail, the
#                                     first $RUN_STDOUT_LINES (default 30) lines of stdout and 10
#                                     of stderr printed, and returns 1
#   expect_error STATUS PATTERN CMD ARGS...  run STATUS CMD..., then ok when stderr is exactly
#                                     one line matching the extended regular expression PATTERN,
#                                     else fail with the stderr printed
#   expect STATUS PATTERN CMD ARGS... CMD (timeout 60) exits with STATUS and prints $WANT_LINES
#                                     (default 1) lines on stderr, the first matching the extended
#                                     regular expression PATTERN: "ok: CMD ARGS -> <stderr>", else
#                                     fail with the status, the line count and the stderr printed
#   expect_saying STATUS TEXT CMD ARGS...  CMD exits with STATUS and prints exactly one line on
#                                     stderr, "<program>: error: ..." containing TEXT (a fixed
#                                     string): "ok: <program> ARGS -> STATUS: <stderr>", else fail
# Needs $WORK (a directory of the caller's, e.g. from mktemp -d). Sets failures=0: the caller
# ends with `echo "$failures failure(s)"; [ "$failures" -eq 0 ]`.
failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}
ok() { echo "ok: $*"; }

run() {
  local want=$1 status=0
  shift
  timeout 60 "$@" >"$WORK/out" 2>"$WORK/err" || status=$?
  if [ "$status" -ne "$want" ]; then
    fail "$* -> status $status (want $want)"
    sed 's/^/  stdout: /' "$WORK/out" | head -"${RUN_STDOUT_LINES:-30}"
    sed 's/^/  stderr: /' "$WORK/err" | head -10
    return 1
  fi
}

expect_error() {
  local want=$1 pattern=$2
  shift 2
  if run "$want" "$@"; then
    if [ "$(wc -l <"$WORK/err")" -eq 1 ] && grep -Eq -- "$pattern" "$WORK/err"; then
      ok "$(cat "$WORK/err")"
    else
      fail "$*: stderr does not match '$pattern':"
      sed 's/^/  stderr: /' "$WORK/err" | head -10
    fi
  fi
}

expect() {
  local want=$1 pattern=$2 status=0 lines
  shift 2
  timeout 60 "$@" >"$WORK/out" 2>"$WORK/err" || status=$?
  lines=$(wc -l <"$WORK/err")
  if [ "$status" -ne "$want" ] || [ "$lines" -ne "${WANT_LINES:-1}" ] ||
    ! head -1 "$WORK/err" | grep -Eq -- "$pattern"; then
    fail "$*"
    echo "  status $status (want $want), $lines stderr lines (want ${WANT_LINES:-1}), pattern: $pattern"
    sed 's/^/  stderr: /' "$WORK/err" | head -20
  else
    echo "ok: $* -> $(cat "$WORK/err")"
  fi
}

expect_saying() {
  local want=$1 text=$2 program status=0 err
  program=$(basename "$3")
  err=$(timeout 60 "${@:3}" 2>&1 >/dev/null) || status=$?
  shift 3
  if [ "$status" -ne "$want" ]; then
    fail "$program $*: status $status (expected $want): $err"
  elif [ "$(printf '%s\n' "$err" | wc -l)" -ne 1 ]; then
    fail "$program $*: not one line: $err"
  else
    case "$err" in
      "$program: error: "*"$text"*) echo "ok: $program $* -> $status: $err" ;;
      *) fail "$program $*: '$err' does not say '$text'" ;;
    esac
  fi
}
