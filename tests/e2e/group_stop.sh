#!/usr/bin/env bash
# The group stops as one: on Ctrl-C (SIGINT) the recording is complete and
# readable and no process is left; when the commander dies (it is never
# restarted: a new one would start its trajectory over), the others stop and
# the group reports it; every process has its own output file. The test waits
# for states (scans recorded, the commander driving), not for times.
source "$(dirname "$0")/lib.bash" "$@"
run_group() {  # runs the group in the background, records its pid
  # Job control, so the background group does not inherit SIGINT as ignored
  # (as it would from a non-interactive shell) and Ctrl-C can reach it.
  set -m
  scripts/agvcal-group --sim config/sims/diff_robot.yaml --trajectory default \
    --speed 2 --log "$TMP/$1.log" --run-dir "$TMP/$1" >>"$TMP/$1.out" 2>&1 &
  group=$!
  set +m
}
# Ctrl-C once the recording holds 200 scans (about 40 motions, 5 % of the trajectory; the final
# solve needs 20 intervals). Not the scan matcher's or the solver's own progress, which a loaded
# machine can delay past the trajectory's end: on Ctrl-C each process first handles everything
# it received before it stops, so the final solve has every scan recorded.
run_group interrupted
wait_for 120 "200 scans recorded" at_least 200 recorded SCAN "$TMP/interrupted.log"
kill -INT "$group"; wait "$group"; code=$?
[ "$code" -eq 130 ] && pass "Ctrl-C: group exits 130" || fail "Ctrl-C: group exited $code; $(tail -5 "$TMP/interrupted.out")"
expect_status 0 "Ctrl-C: the recording is complete and decodes" "$AGVCAL" info "$TMP/interrupted.log"
grep -q WHEELS "$TMP/stdout" && pass "Ctrl-C: recording has WHEELS" || fail "Ctrl-C: recording lacks WHEELS"
for p in logger solver scanmatch sim commander; do
  [ -e "$TMP/interrupted/$p.out" ] || fail "no output file of $p"
done
grep -q "agvcal-commander: stop requested" "$TMP/interrupted/commander.out" \
  && pass "each process's output in its own file" || fail "commander.out: $(cat "$TMP/interrupted/commander.out")"
python3 -c 'import json, sys; assert json.load(open(sys.argv[1]))["residual"]["intervals"] >= 25' \
  "$TMP/interrupted/RESULT.json" && pass "the solver's final solve wrote RESULT.json on Ctrl-C" \
  || fail "no RESULT.json; solver.out: $(tail -3 "$TMP/interrupted/solver.out")"
# The logger stopped last and drained: the solver's final estimate is in the recording.
grep -q "drained" "$TMP/interrupted/logger.out" && pass "the logger drained before it stopped" \
  || fail "logger.out: $(tail -3 "$TMP/interrupted/logger.out")"
grep -q "agvcal-group: the recording holds [0-9]* messages" "$TMP/interrupted.out" \
  && pass "the group says how many messages it recorded" || fail "no count: $(tail -3 "$TMP/interrupted.out")"
no_orphans

# The commander killed once it drives.
run_group crashed
wait_for 120 "the commander driving" at_least 20 recorded DRIVE_CMD "$TMP/crashed.log"
commander=$(group_pid "$TMP/crashed" commander)
[ -n "$commander" ] && kill -KILL "$commander" && pass "commander killed" || fail "no commander to kill"
wait "$group"; code=$?
[ "$code" -eq 1 ] && pass "a dead process stops the group with exit 1" || fail "group exited $code after a crash"
grep -q "commander exited" "$TMP/crashed.out" && pass "the group names the dead process" || fail "no message naming the commander: $(tail -3 "$TMP/crashed.out")"
no_orphans
finish
