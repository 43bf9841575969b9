# Sourced by the command-line tests: checks of a program's start-up errors.
#   expect_error PATTERN CMD ARGS...   CMD exits with status 2 and prints exactly one line on
#                                      stderr, matching the extended regular expression PATTERN
# Needs `fail MESSAGE` (live_test_lib.sh gives it; else this defines it).
if ! declare -F fail >/dev/null; then
  fail() { echo "FAIL: $*" >&2; exit 1; }
fi
expect_error() {
  local pattern=$1 err rc
  shift
  set +e
  err=$("$@" 2>&1 >/dev/null)
  rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "$*: status $rc (expected 2): $err"
  [ "$(printf '%s\n' "$err" | wc -l)" -eq 1 ] || fail "$*: more than one line: $err"
  printf '%s\n' "$err" | grep -Eq -- "$pattern" || fail "$*: expected /$pattern/, got: $err"
  echo "ok: $err"
}
