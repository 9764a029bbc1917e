#!/usr/bin/env bash
# The group on the bundled sample, run as README and docs/live.md show it to a new user
# (scripts/agvcal-group --replay logs/forklift_demo.log --robot config/robots/forklift.yaml
# --speed 2, no --run-dir), in a private network namespace:
#  - the dashboard has the solver's estimates during the replay: the recording holds
#    intermediate CALIB_ESTIMATEs with status ok before the final one (with `--every 200`, the
#    old default, none: the sample has 48 motions, and the dashboard said "waiting for the
#    solver" throughout);
#  - the final result is offline's, byte for byte (intermediate solves change nothing);
#  - the group ends by printing the calibration and where RESULT.json is;
#  - the run directory is outside the checkout: ~/agvcal-runs/run-*.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log
export HOME=$TMP/home
mkdir -p "$HOME"
before=$(ls -d logs/run-* 2>/dev/null | wc -l)

expect_status 0 "offline solve" "$AGVCAL" solve "$robot" "$log" --quiet --out "$TMP/offline.json"
scripts/netns-run scripts/agvcal-group --replay "$log" --robot "$robot" --speed 2 >"$TMP/group.out" 2>&1
code=$?
[ "$code" -eq 0 ] && pass "the group ends with the replay (exit 0)" || fail "group exit $code: $(tail -3 "$TMP/group.out")"

runs=("$HOME"/agvcal-runs/run-*)
run=${runs[0]}
[ "${#runs[@]}" -eq 1 ] && [ -s "$run/RESULT.json" ] && pass "the run directory is $run" \
  || fail "no run directory in ~/agvcal-runs: $(ls -la "$HOME" "$HOME/agvcal-runs" 2>&1)"
[ "$(ls -d logs/run-* 2>/dev/null | wc -l)" -eq "$before" ] && pass "nothing written into the checkout's logs/" \
  || fail "a run directory in the checkout's logs/"
grep -q "run directory $run" "$TMP/group.out" && pass "the group says where its run directory is at start" \
  || fail "the run directory is not named: $(head -3 "$TMP/group.out")"

"$CHECK" estimates "$run/recording.log" >"$TMP/estimates.txt"
intermediate=$(grep -c '^ok ' "$TMP/estimates.txt")
[ "$intermediate" -ge 2 ] && [ "$(tail -1 "$TMP/estimates.txt" | cut -d' ' -f1)" = final ] \
  && pass "$intermediate estimates before the final one ($(tr '\n' ',' <"$TMP/estimates.txt"))" \
  || fail "the dashboard had no estimate during the replay: $(tr '\n' ',' <"$TMP/estimates.txt")"

python3 tests/tools/without_provenance.py "$TMP/offline.json" >"$TMP/offline.txt"
python3 tests/tools/without_provenance.py "$run/RESULT.json" >"$TMP/live.txt"
cmp -s "$TMP/offline.txt" "$TMP/live.txt" && pass "live RESULT.json is agvcal solve's (but for its provenance)" \
  || fail "live RESULT.json differs from offline: $(diff "$TMP/offline.txt" "$TMP/live.txt" | head -10)"

# The calibration at the end: every value of RESULT.json, named as `agvcal solve` names it, with its unit.
grep -q "^agvcal-group: the calibration, written to $run/RESULT.json:$" "$TMP/group.out" \
  && pass "the group names RESULT.json" || fail "RESULT.json not named at the end: $(tail -12 "$TMP/group.out")"
python3 - "$run/RESULT.json" "$TMP/group.out" <<'PY' && pass "the group prints the calibration" || fail "calibration not printed: $(tail -12 "$TMP/group.out")"
import json, re, sys
result = json.load(open(sys.argv[1]))
text = open(sys.argv[2]).read()
names = list(result["params"]) + ["lidar2d." + k for k in ("x", "y", "yaw")]
missing = [n for n in names if not re.search(r"^  %s +[-0-9.]+ ± [0-9.]+ (m|rad)" % re.escape(n), text, re.M)]
print("missing:", missing) if missing else None
sys.exit(1 if missing else 0)
PY
tail -1 "$TMP/group.out" | grep -q "done; recording in $run/recording.log, calibration in $run/RESULT.json$" \
  && pass "the last line names the recording and RESULT.json" || fail "last line: $(tail -1 "$TMP/group.out")"
no_orphans
finish
