#!/usr/bin/env bash
# ips-site's command line (issue 23): --help with its example; a site file that does not load at
# start stops it with one line naming file, line and field and status 2, as --site does in every
# program (the loader's errors and the estimators' own section checks); bad flags status 2.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
. "$ROOT/tests/integration/cli_check_lib.sh"

if run 0 "$BIN/ips-site" --help; then
  for want in "Example" "ips-site /etc/ips/lab.yaml --period 2" "--period" "--lcm-url" \
    "--channel" "--log-level" "FILE"; do
    grep -qF -- "$want" "$WORK/out" && ok "--help has '$want'" || fail "--help lacks '$want'"
  done
  grep -q -- "^  --site" "$WORK/out" && fail "--help offers --site (the file is the argument)"
fi

cat >"$WORK/bad.yaml" <<'YAML'
name: broken
anchors:
  - {id: A1, position: [0, 0]}
YAML
sed 's/range_sigma_m: 0.10/range_sigma_m: 0/' "$ROOT/config/sites/lab.yaml" >"$WORK/param.yaml"
cp "$ROOT/config/sites/lab-plan.svg" "$WORK/"  # the floor plan, beside the site file
param_line=$(grep -n "range_sigma_m: 0$" "$WORK/param.yaml" | cut -d: -f1)
printf 'name: x\nanchors: [ {id: A1\n' >"$WORK/syntax.yaml"

expect_error 2 "^ips-site: error: .*/bad.yaml:3: anchors\[0\]\.position: expected a list of 3 numbers \[x, y, z\]$" \
  "$BIN/ips-site" "$WORK/bad.yaml"
expect_error 2 "^ips-site: error: .*/param.yaml:$param_line: estimators\.uwb_twr\.range_sigma_m: must be in \(0, 1e6\]$" \
  "$BIN/ips-site" "$WORK/param.yaml"
expect_error 2 "^ips-site: error: .*/syntax.yaml:[0-9]+:[0-9]+: YAML syntax error" \
  "$BIN/ips-site" "$WORK/syntax.yaml"
expect_error 2 "^ips-site: error: $WORK/none.yaml: cannot read: No such file or directory$" \
  "$BIN/ips-site" "$WORK/none.yaml"
expect_error 2 "^ips-site: error: FILE is required" "$BIN/ips-site"
expect_error 2 "^ips-site: error: --period: Value 0 not in range" \
  "$BIN/ips-site" "$ROOT/config/sites/lab.yaml" --period 0
expect_error 2 "^ips-site: error: The following arguments? (was|were) not expected: .*--site" \
  "$BIN/ips-site" "$ROOT/config/sites/lab.yaml" --site x.yaml
expect_error 1 "^ips-site: error: cannot open LCM URL 'bogus://nowhere'" \
  "$BIN/ips-site" "$ROOT/config/sites/lab.yaml" --lcm-url bogus://nowhere

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
