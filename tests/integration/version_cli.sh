#!/usr/bin/env bash
# --version on every program in the build's bin directory (every ips-* file there, so that a new
# program is covered without touching this test): exit 0, nothing on stderr, one line
# "<program> <project version> (git <describe>, <build type>)" on stdout; the version is
# CMakeLists.txt's. Programs with subcommands answer it before and after each one.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"  # fail, ok, run, expect_error; counts failures

version=$(sed -n 's/^project(ips_fusion VERSION \([0-9.]*\).*/\1/p' "$ROOT/CMakeLists.txt")
[ -n "$version" ] || fail "no project(ips_fusion VERSION ...) in $ROOT/CMakeLists.txt"
programs=0

# check_version NAME PROGRAM [SUBCOMMAND]: PROGRAM [SUBCOMMAND] --version exits 0 and prints one
# line "NAME <version> (git <describe>, <build type>)" and nothing on stderr.
check_version() {
  local name=$1 program=$2 line
  run 0 "$program" "${@:3}" --version || return 1
  line=$(cat "$WORK/out")
  if [ "$(wc -l <"$WORK/out")" -ne 1 ] || [ -s "$WORK/err" ]; then
    fail "$name${3:+ $3} --version: not one line on stdout and nothing on stderr:"
    sed 's/^/  stdout: /' "$WORK/out" | head -5
    sed 's/^/  stderr: /' "$WORK/err" | head -5
  elif [[ "$line" =~ ^$name\ ${version//./\\.}\ \(git\ [^\ ,\(\)]+,\ [A-Za-z]+\)$ ]]; then
    ok "$name${3:+ $3} --version: $line"
  else
    fail "$name${3:+ $3} --version: '$line' is not '$name $version (git <describe>, <build type>)'"
  fi
}

for program in "$BIN"/ips-*; do
  [ -f "$program" ] && [ -x "$program" ] || continue
  name=$(basename "$program")
  programs=$((programs + 1))
  check_version "$name" "$program" || continue
  # After a subcommand too (the common options fall through to the program: the convention of
  # every program with subcommands), e.g. `ips-pdr calibrate --version`.
  timeout 20 "$program" --help 2>/dev/null </dev/null |
    awk '/^Subcommands:$/ { on = 1; next } on && /^[^ ]/ { on = 0 } on && /^  [a-z]/ { print $1 }' \
      >"$WORK/subcommands"
  while read -r sub; do
    check_version "$name" "$program" "$sub"
  done <"$WORK/subcommands"
done
# An empty or half-built bin directory is not a pass: the tree has more than 20 programs.
[ "$programs" -ge 20 ] || fail "only $programs ips-* programs in $BIN"
echo "$programs programs"

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
