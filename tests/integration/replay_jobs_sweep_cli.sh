#!/usr/bin/env bash
# ips-replay --jobs, --lanes, --set and --out-dir (issue 25): a 4-tag lab log replayed on one thread and on
# two gives the same bytes; with --lanes 3 on one lane thread and on three, the same bytes too,
# --lanes 1 the bytes of no lanes, and every tag fused; a sweep over a site setting gives one
# row per value, sorted, each row's score the one ips-eval gives the replay of that
# configuration; bad --set values are refused, and a configuration the estimators refuse is a
# failed row, not a crash.
set -uo pipefail
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

"$BIN/ips-sim" --scenario lab --tags 4 --seed 3 --duration 30 --out "$WORK/in.lcm" --log-level warn
for j in 1 2; do
  "$BIN/ips-replay" "$WORK/in.lcm" --out "$WORK/j$j.lcm" --jobs "$j" 2>"$WORK/j$j.err" ||
    fail "--jobs $j: $(cat "$WORK/j$j.err")"
done
grep -q '; 1 thread)' "$WORK/j1.err" && grep -q '; 2 threads)' "$WORK/j2.err" &&
  echo "ok: --jobs 1 and 2 say their threads" || fail "thread counts not said: $(grep 'events in' "$WORK"/j*.err)"
cmp -s "$WORK/j1.lcm" "$WORK/j2.lcm" && echo "ok: --jobs 2 wrote the same bytes as --jobs 1" ||
  fail "--jobs 2 and --jobs 1 differ"
[ "$(stat -c %s "$WORK/j1.lcm")" -gt 1000000 ] || fail "the replay wrote little: $(stat -c %s "$WORK/j1.lcm") bytes"

# --lanes: the output depends on the lanes, not on the threads.
for run in "3 1" "3 3" "1 2"; do
  set -- $run
  "$BIN/ips-replay" "$WORK/in.lcm" --out "$WORK/l$1-j$2.lcm" --lanes "$1" --jobs "$2" 2>"$WORK/l$1-j$2.err" ||
    fail "--lanes $1 --jobs $2: $(cat "$WORK/l$1-j$2.err")"
done
set --
grep -q "; 5 threads, 3 lanes)" "$WORK/l3-j3.err" && grep -q "CPU: lanes [0-9.]* to [0-9.]* s each" "$WORK/l3-j3.err" &&
  echo "ok: --lanes 3 --jobs 3 says its threads, lanes and CPU" || fail "lanes not said: $(grep -E 'events in|CPU' "$WORK/l3-j3.err")"
cmp -s "$WORK/l3-j1.lcm" "$WORK/l3-j3.lcm" && echo "ok: --lanes 3: --jobs 3 wrote the same bytes as --jobs 1" ||
  fail "--lanes 3: --jobs 3 and --jobs 1 differ"
cmp -s "$WORK/l1-j2.lcm" "$WORK/j1.lcm" && echo "ok: --lanes 1 wrote the bytes of the replay without lanes" ||
  fail "--lanes 1 and no lanes differ"
fused=$("$BIN/ips-eval" --json "$WORK/l3-j1.lcm" | python3 -c '
import json, sys
print(sorted(r["tag"] for r in json.load(sys.stdin)["rows"] if r["channel"] == "POSE_FUSED" and r["count"] > 200))')
[ "$fused" = "['T1', 'T1-2', 'T1-3', 'T1-4']" ] && echo "ok: --lanes 3 fused every tag: $fused" || fail "--lanes 3 fused $fused"
"$BIN/ips-replay" "$WORK/in.lcm" --out x.lcm --lanes 0 2>"$WORK/e0" >/dev/null
[ $? = 2 ] && grep -q "lanes" "$WORK/e0" && echo "ok: --lanes 0 refused" || fail "--lanes 0: $(cat "$WORK/e0")"

# A sweep: three values of ips-fuse's range noise on the lab's site file.
cp "$ROOT/config/sites/lab.yaml" "$ROOT/config/sites/lab-plan.svg" "$WORK/"
"$BIN/ips-replay" "$WORK/in.lcm" --site "$WORK/lab.yaml" --set estimators.fuse.range_sigma_m=0.3,0.05,0.1 \
  --jobs 2 >"$WORK/sweep.txt" 2>"$WORK/sweep.err" || fail "sweep: $(cat "$WORK/sweep.err")"
cat "$WORK/sweep.txt"
rows=$(grep -cE '^  [0-9]+ +0\.[0-9]+ ' "$WORK/sweep.txt")
[ "$rows" = 3 ] && echo "ok: 3 rows" || fail "$rows rows (3 wanted)"
awk '/^  [0-9]+ +0\./ { if (prev != "" && $4 + 0 < prev + 0) bad = 1; prev = $4 } END { exit bad }' \
  "$WORK/sweep.txt" && echo "ok: sorted by rmse" || fail "rows not sorted by rmse"
# Each row's rmse is what ips-eval says of that configuration's replay.
while read -r _ value _ rmse _; do
  # estimators is lab.yaml's last section and has no fuse: one is added with the value.
  grep -q "^  fuse:" "$WORK/lab.yaml" && fail "config/sites/lab.yaml has a fuse section: adapt the test"
  { cat "$WORK/lab.yaml"; printf '  fuse:\n    range_sigma_m: %s\n' "$value"; } >"$WORK/site-$value.yaml"
  "$BIN/ips-replay" "$WORK/in.lcm" --site "$WORK/site-$value.yaml" --out "$WORK/r-$value.lcm" \
    --log-level warn 2>/dev/null || fail "replay with range_sigma_m $value"
  eval_rmse=$("$BIN/ips-eval" --json --by channel "$WORK/r-$value.lcm" | python3 -c '
import json, sys
rows = [r for r in json.load(sys.stdin)["rows"] if r["channel"] == "POSE_FUSED"]
print("%.3f" % rows[0]["rmse_h"])')
  [ "$eval_rmse" = "$rmse" ] && echo "ok: range_sigma_m $value: rmse $rmse, as ips-eval says" ||
    fail "range_sigma_m $value: sweep rmse $rmse, ips-eval $eval_rmse"
done < <(grep -E '^  [0-9]+ +0\.[0-9]+ ' "$WORK/sweep.txt")
# JSON: the same rows.
"$BIN/ips-replay" "$WORK/in.lcm" --site "$WORK/lab.yaml" --set estimators.fuse.range_sigma_m=0.3,0.05,0.1 \
  --json --out-dir "$WORK/sweep-out" --log-level warn >"$WORK/sweep.json" || fail "sweep --json"
python3 - "$WORK/sweep.json" <<'PY' && echo "ok: --json" || fail "--json rows"
import json, sys
j = json.load(open(sys.argv[1]))
rows = j["rows"]
assert j["settings"] == ["estimators.fuse.range_sigma_m"] and len(rows) == 3, j
means = [r["mean"] for r in rows]
assert means == sorted(means), means
assert {r["values"]["estimators.fuse.range_sigma_m"] for r in rows} == {"0.3", "0.05", "0.1"}
assert all(r["logs"][0]["count"] > 1000 for r in rows), rows
PY
# --out-dir: each configuration's replay, the same bytes as a replay with that site, and an index.
python3 - "$WORK/sweep.json" "$WORK" <<'PY' && echo "ok: --out-dir replays as ips-replay --out writes them" || fail "--out-dir"
import filecmp, json, os, sys
j, work = json.load(open(sys.argv[1])), sys.argv[2]
index = open(os.path.join(work, "sweep-out", "index.tsv")).read().splitlines()
assert index[0] == "file\testimators.fuse.range_sigma_m\tlog\terror", index
assert sorted(l.split("\t")[0] for l in index[1:]) == ["config-1.lcm", "config-2.lcm", "config-3.lcm"], index
for r in j["rows"]:
    value = r["values"]["estimators.fuse.range_sigma_m"]
    [out] = r["outputs"]
    assert filecmp.cmp(out, os.path.join(work, "r-%s.lcm" % value), shallow=False), (out, value)
    assert any(l.startswith(os.path.basename(out) + "\t" + value + "\t") for l in index), index
PY
"$BIN/ips-replay" "$WORK/in.lcm" --out x.lcm --out-dir "$WORK/d" 2>"$WORK/e3" >/dev/null
[ $? = 2 ] && grep -q "is for a sweep" "$WORK/e3" && echo "ok: $(cat "$WORK/e3")" || fail "--out-dir without --set: $(cat "$WORK/e3")"

# Refusals: a malformed --set (status 2); a value the estimators refuse is a failed row; every
# row failed is status 1.
"$BIN/ips-replay" "$WORK/in.lcm" --set "estimators.fuse.range_sigma_m" 2>"$WORK/e1" >/dev/null
[ $? = 2 ] && grep -q "not KEY=" "$WORK/e1" && echo "ok: $(cat "$WORK/e1")" || fail "malformed --set: $(cat "$WORK/e1")"
"$BIN/ips-replay" "$WORK/in.lcm" --out x.lcm --set a.b=1 2>"$WORK/e2" >/dev/null
[ $? = 2 ] && grep -q "does not apply" "$WORK/e2" && echo "ok: $(cat "$WORK/e2")" || fail "--out with --set: $(cat "$WORK/e2")"
"$BIN/ips-replay" "$WORK/in.lcm" --site "$WORK/lab.yaml" --set estimators.fuse.range_sigma_m=-1,0.1 \
  --log-level warn >"$WORK/bad.txt" 2>&1
status=$?
[ $status = 0 ] && grep -Eq '^  1 +0\.1 ' "$WORK/bad.txt" && grep -Eq '^  2 +-1 +failed: .*range_sigma_m' "$WORK/bad.txt" &&
  echo "ok: a refused value is a failed row, last" || fail "refused value: status $status: $(cat "$WORK/bad.txt")"
"$BIN/ips-replay" "$WORK/in.lcm" --site "$WORK/lab.yaml" --set estimators.fuse.nonsense=1 \
  --log-level warn >"$WORK/bad2.txt" 2>&1
status=$?
[ $status = 1 ] && grep -q 'unknown field' "$WORK/bad2.txt" && echo "ok: every row failed: status 1" ||
  fail "all failed: status $status: $(cat "$WORK/bad2.txt")"

[ "$failures" = 0 ] && echo "replay_jobs_sweep_cli: ok" || exit 1
