#!/usr/bin/env bash
# The helper scripts' command lines: every script answers --help; scripts/install-deps's package
# sets (demo within all, the demo's runtime tools in demo, the test tools only in all), its
# refusals, and that an installed set only checks (this suite runs after scripts/test installed
# `all`). Nothing is installed here: with a package missing, the set check is skipped.
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"

for s in "$ROOT"/scripts/*; do
  [ -f "$s" ] && [ -x "$s" ] || continue
  name=scripts/$(basename "$s")
  if run 0 "$s" --help; then
    if grep -q . "$WORK/out"; then ok "$name --help"; else fail "$name --help printed nothing"; fi
  fi
done

deps=$ROOT/scripts/install-deps
run 0 "$deps" --list demo && cp "$WORK/out" "$WORK/demo.txt"
run 0 "$deps" --list all && cp "$WORK/out" "$WORK/all.txt"
run 0 "$deps" --list && cp "$WORK/out" "$WORK/default.txt"
if cmp -s "$WORK/all.txt" "$WORK/default.txt"; then ok "install-deps: the default set is all"
else fail "install-deps: the default set is not all"; fi
outside=$(sort "$WORK/demo.txt" | comm -23 - <(sort "$WORK/all.txt"))
[ -z "$outside" ] && ok "install-deps: demo is within all" || fail "install-deps: demo but not all: $outside"
# What scripts/demo runs beside our programs, and what it builds with.
for p in build-essential cmake ninja-build liblcm-dev liblcm-bin libeigen3-dev libyaml-cpp-dev \
         libcli11-dev libspdlog-dev libgtest-dev libbenchmark-dev librsvg2-bin iproute2; do
  grep -qx "$p" "$WORK/demo.txt" || fail "install-deps: demo lacks $p"
done
# The test suite's heavy tools stay out of the demo's set (they are most of a fresh install).
for p in chromium chromium-driver clang default-jdk-headless xvfb stress-ng faketime; do
  grep -qx "$p" "$WORK/demo.txt" && fail "install-deps: demo installs the test tool $p"
  grep -qx "$p" "$WORK/all.txt" || fail "install-deps: all lacks $p"
done
ok "install-deps: $(wc -l <"$WORK/demo.txt") packages in demo, $(wc -l <"$WORK/all.txt") in all"
expect 2 "^install-deps: unknown package set 'everything' \(demo or all\)$" "$deps" everything
expect 2 "^scripts/build: unknown build kind 'debug' \(release or asan\)$" "$ROOT/scripts/build" debug

installed=1
while read -r p; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || installed=0
done <"$WORK/all.txt"
if [ "$installed" = 1 ]; then
  for set in demo all; do
    if run 0 "$deps" "$set"; then
      if [ -s "$WORK/err" ]; then fail "install-deps $set with all installed said: $(head -1 "$WORK/err")"
      else ok "install-deps $set: all installed, nothing to do"; fi
    fi
  done
else
  echo "note: a package of 'all' is missing here; the installed-set check is skipped"
fi

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
