#!/usr/bin/env bash
# The commander stops the robot when its inputs go stale: wheel states are
# replayed for a while and then cease; the commander must report stale inputs
# and send stop commands (in a private network namespace).
source "$(dirname "$0")/lib.bash" "$@"
"$AGVCAL" simulate config/sims/diff_robot.yaml "$TMP/wheels.log" --trajectory demo --quiet
start_logger "$TMP/commands.log" 'DRIVE_CMD|COMMANDER_STATUS'
"$BUILD/agvcal-commander" config/robots/diff_robot.yaml --trajectory default --stale-timeout 0.5 \
  2>"$TMP/commander.err" & commander=$!
# About 7 s of wheel states, then silence: the commander says it holds the robot.
wait_ready "$TMP/commands.log" commander &&
  timeout 60 lcm-logplayer -s 4 -e '^(WHEELS|SCAN)$' "$TMP/wheels.log" >/dev/null 2>&1
wait_for 30 "the commander to hold the robot on stale inputs (its HEARTBEAT: held)" \
  beat_now "$TMP/commands.log" commander "^held: no "
stop $commander agvcal-commander && pass "commander exits 0 on SIGINT" || fail "commander exit: $(tail -3 "$TMP/commander.err")"
stop_logger "$TMP/commands.log"
if "$CHECK" stale "$TMP/commands.log"; then pass "stale inputs stop the robot"; else fail "stale inputs did not stop the robot"; fi
no_orphans
finish
