# Sourced by the command-line tests: checks of a program's start-up errors.
#   expect_error PATTERN CMD ARGS...   CMD exits with status 2 and prints exactly one line on
#                                      stderr, matching the extended regular expression PATTERN
#   expect_error_saying TEXT CMD ARGS... the same, the line being "<program>: error: ..." and
#                                      containing TEXT (a fixed string)
# Needs `fail MESSAGE` (live_test_lib.sh gives it; else this defines it).
if ! declare -F fail >/dev/null; then
  fail() { echo "FAIL: $*" >&2; exit 1; }
fi
expect_error() {
  local pattern=$1 rc
  err=
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
expect_error_saying() {
  local text=$1 program
  program=$(basename "$2")
  expect_error "^$program: error: " "${@:2}" >/dev/null
  printf '%s\n' "$err" | grep -qF -- "$text" || fail "${*:2}: '$err' does not say '$text'"
  echo "ok: $err"
}
