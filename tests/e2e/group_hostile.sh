#!/usr/bin/env bash
# Hostile input through the live group (issue 17 items 4 and 5): the sample recording is
# replayed through scripts/agvcal-group (lcm-logger, agvcal-scanmatch, agvcal-solver under
# supervisord, in a private network namespace).
#  - One WHEELS message with a non-finite position: the solver skips it and lives on (no
#    restart), says so on its HEARTBEAT (what the dashboard shows) and writes RESULT.json.
#  - One WHEELS stamp +8.4 s ahead (a flipped bit): that sample alone is left out, live as
#    offline; the result equals `agvcal solve`'s on the same recording.
#  - Every SCAN with a NaN angle increment: no motion, the final solve fails, no RESULT.json:
#    the group exits non-zero and gives the solver's reason.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log
group() {  # group RUN_NAME RECORDING: the replay through the group
  scripts/netns-run scripts/agvcal-group --replay "$2" --robot "$robot" --speed 2 \
    --run-dir "$TMP/$1" >"$TMP/$1.out" 2>&1
}
# The states the solver's HEARTBEAT carried, from the group's recording.
solver_states() { python3 tests/tools/heartbeats.py "$1" solver; }

python3 tests/tools/wheel_log.py $log "$TMP/nan.log" 1000 position drive nan
group nan "$TMP/nan.log"; code=$?
[ "$code" -eq 0 ] && pass "a NaN wheel position: the group ends with the replay (exit 0)" ||
  fail "NaN wheel position: group exit $code: $(tail -3 "$TMP/nan.out")"
spawns=$(grep -c "spawned: 'solver'" "$TMP/nan/supervisord.log")
[ "$spawns" -eq 1 ] && pass "the solver was never restarted" || fail "solver spawned $spawns times: $(cat "$TMP/nan/solver.out")"
grep -q "agvcal-solver: ignoring a message (reported once): .*WHEELS.*not finite" "$TMP/nan/solver.out" &&
  pass "the solver says what it skipped" || fail "solver.out: $(cat "$TMP/nan/solver.out")"
[ -s "$TMP/nan/RESULT.json" ] && pass "RESULT.json written" || fail "no RESULT.json"
solver_states "$TMP/nan/recording.log" >"$TMP/states"
grep -q "running; 1 bad message skipped" "$TMP/states" && pass "the solver's HEARTBEAT counts the skipped message" ||
  fail "solver HEARTBEAT states: $(sort -u "$TMP/states" | head -5)"

# One flipped bit in one WHEELS stamp: the solver delivers each message once by stamp; the
# far stamp must not make it take the 8.4 s of samples after it for ones already delivered.
python3 tests/tools/wheel_log.py $log "$TMP/stamp.log" 1000 utime 8388608
"$AGVCAL" solve $robot "$TMP/stamp.log" --quiet --out "$TMP/stamp_offline.json" >/dev/null 2>&1
group stamp "$TMP/stamp.log"; code=$?
[ "$code" -eq 0 ] && pass "a WHEELS stamp +8.4 s: the group ends with the replay (exit 0)" ||
  fail "+8.4 s stamp: group exit $code: $(tail -3 "$TMP/stamp.out")"
! grep -q "wheel states, the solver received" "$TMP/stamp/solver.out" &&
  pass "the solver received every wheel state the recording holds" ||
  fail "solver lost wheel states: $(grep "solver received" "$TMP/stamp/solver.out")"
python3 - "$TMP/stamp_offline.json" "$TMP/stamp/RESULT.json" <<'PY' && pass "+8.4 s stamp: the group's result equals agvcal solve's" ||
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
for k in ("params", "lidar2d", "residual"):
    assert a[k] == b[k], (k, a[k], b[k])
PY
  fail "+8.4 s stamp: the group's result differs from agvcal solve's: $(diff "$TMP/stamp_offline.json" "$TMP/stamp/RESULT.json" | head -8)"

# Every scan's angle_increment (after the hash, utime and angle_min) NaN.
python3 tests/tools/corrupt_log.py $log "$TMP/noscan.log" SCAN all 20 =0x7fc00000
group noscan "$TMP/noscan.log"; code=$?
[ "$code" -ne 0 ] && pass "no usable scan: the group fails (exit $code)" || fail "no usable scan: group exit 0"
[ ! -e "$TMP/noscan/RESULT.json" ] && pass "no RESULT.json" || fail "a RESULT.json: $(head -c 300 "$TMP/noscan/RESULT.json")"
grep -q "agvcal-group: player finished, but the solver wrote no RESULT.json (agvcal-solver: error: " "$TMP/noscan.out" &&
  pass "the group names the missing result and the solver's reason" || fail "group said: $(tail -3 "$TMP/noscan.out")"
no_orphans
finish
