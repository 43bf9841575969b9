#!/usr/bin/env bash
# docs_flags.sh BIN_DIR ROOT [--update]: the program pages document every flag.
# For every ips-* program in BIN_DIR: docs/programs/<program>.md exists, and every long flag
# (--name) that `<program> --help` prints, and the --help of each subcommand it lists, appears on
# that page (the flags every program shares through core/cli may instead be on
# docs/programs/README.md). Also: no page of README.md or docs/ points outside the repository
# (../shared), and every docs/programs/<program>.md belongs to a program that was built (or is
# one that only some builds have). Failures name the program and the flag; exit 1 on any.
# --update: rewrite the help blocks of the pages (between `<!-- begin help: CMD -->` and
# `<!-- end help -->`) from the binaries' --help, then check.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
UPDATE=${3:-}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"  # fail, ok; counts failures
PAGES="$ROOT/docs/programs"

# help CMD... : CMD's --help on stdout (status 0 expected), or fail.
help() {
  local status=0
  timeout 20 "$BIN/$1" "${@:2}" --help >"$WORK/help" 2>"$WORK/help.err" </dev/null || status=$?
  if [ "$status" -ne 0 ]; then
    fail "$* --help: status $status: $(head -3 "$WORK/help.err")"
    return 1
  fi
  cat "$WORK/help"
}

# subcommands: the names listed under CLI11's "Subcommands:" heading of the help on stdin.
subcommands() {
  awk '/^Subcommands:$/ { on = 1; next } on && /^[^ ]/ { on = 0 } on && /^  [a-z]/ { print $1 }'
}

# The help blocks: regenerate them from the binaries.
if [ "$UPDATE" = "--update" ]; then
  for page in "$PAGES"/*.md; do
    python3 - "$page" "$BIN" <<'EOF' || fail "cannot update $page"
import re, subprocess, sys
page, bin_dir = sys.argv[1], sys.argv[2]
text = open(page).read()
def block(m):
    cmd = m.group(1).split()
    out = subprocess.run([f'{bin_dir}/{cmd[0]}', *cmd[1:], '--help'], capture_output=True,
                         text=True, timeout=20, stdin=subprocess.DEVNULL)
    if out.returncode != 0:
        sys.exit(f'{" ".join(cmd)} --help: status {out.returncode}')
    body = out.stdout.rstrip('\n')
    return f'{m.group(0).splitlines()[0]}\n```\n$ {" ".join(cmd)} --help\n{body}\n```\n<!-- end help -->'
new = re.sub(r'<!-- begin help: ([^>]*?) -->\n.*?<!-- end help -->', block, text, flags=re.S)
if new != text:
    open(page, 'w').write(new)
    print(f'updated {page}')
EOF
  done
fi

# The flags every program has through core/cli add_common_options (and CLI11's --help).
COMMON="--help --version --lcm-url --lcm-queue --lcm-recv-buf --lcm-receiver --busy-poll-us --channel --log-level --site"
# Programs that only some builds have: their pages may stay when they are not built (ips-bench:
# where IPS_BUILD_BENCHMARKS is on, not the sanitizer build).
OPTIONAL="ips-bench"

programs=0
flags_checked=0
for exe in "$BIN"/ips-*; do
  [ -x "$exe" ] && [ -f "$exe" ] || continue
  prog=$(basename "$exe")
  programs=$((programs + 1))
  page="$PAGES/$prog.md"
  if [ ! -f "$page" ]; then
    fail "$prog: no page docs/programs/$prog.md"
    continue
  fi
  grep -q "^# $prog\$" "$page" || fail "$prog: docs/programs/$prog.md does not start with '# $prog'"
  grep -q "($prog.md)" "$PAGES/README.md" || fail "$prog: not in the index docs/programs/README.md"
  help "$prog" >"$WORK/top" || continue
  cmds=("$prog")
  while read -r sub; do cmds+=("$prog $sub"); done < <(subcommands <"$WORK/top")
  for cmd in "${cmds[@]}"; do
    # shellcheck disable=SC2086
    help $cmd >"$WORK/h" || continue
    # Every --name in the help text (option columns and descriptions alike).
    grep -oE -- '--[A-Za-z][A-Za-z0-9_-]*' "$WORK/h" | sed 's/[-_]*$//' | sort -u >"$WORK/flags"
    while read -r flag; do
      flags_checked=$((flags_checked + 1))
      # The flag as a whole word on the page: not a prefix of a longer flag.
      if grep -qE -- "${flag}([^A-Za-z0-9_-]|\$)" "$page"; then
        continue
      fi
      if [[ " $COMMON " == *" $flag "* ]] &&
        grep -qE -- "${flag}([^A-Za-z0-9_-]|\$)" "$PAGES/README.md"; then
        continue
      fi
      fail "$cmd: flag $flag is not documented on docs/programs/$prog.md"
    done <"$WORK/flags"
  done
done
[ "$programs" -gt 0 ] || fail "no ips-* program in $BIN"

# Pages of programs that do not exist.
for page in "$PAGES"/ips-*.md; do
  prog=$(basename "$page" .md)
  [ -x "$BIN/$prog" ] && continue
  [[ " $OPTIONAL " == *" $prog "* ]] && continue
  fail "docs/programs/$prog.md: no program $prog in $BIN"
done

# No link out of the repository from README.md and docs/.
if grep -rnI -- '\.\./shared' "$ROOT/README.md" "$ROOT/docs" >"$WORK/shared"; then
  while read -r line; do fail "points outside the repository: ${line#"$ROOT"/}"; done <"$WORK/shared"
fi

echo "$programs programs, $flags_checked flags checked"
echo "$failures failure(s)"
[ "$failures" -eq 0 ]
