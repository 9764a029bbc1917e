#!/usr/bin/env bash
# Safety of the commander, live (private network namespace): no command exceeds
# the robot file's limits; the operator's stop (`agvcal stop`) holds the robot
# until released, then the trajectory goes on; scans that go stale while wheel
# states still come stop the robot; a commander killed with SIGKILL leaves the
# robot to stop by itself when its last command times out.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml

# 1. Simulator + commander: operator stop and release, then SIGKILL mid-trajectory.
live=$TMP/live.log
start_logger "$live" '.*'
"$BUILD/agvcal-sim" config/sims/forklift.yaml --speed 2 >>"$TMP/live.out" 2>&1 & sim=$!
"$BUILD/agvcal-commander" $robot --trajectory default 2>"$TMP/commander.err" & commander=$!
wait_for 60 "the commander to drive (100 commands)" at_least 100 recorded DRIVE_CMD "$live"
"$AGVCAL" stop --reason "e2e test" >>"$TMP/live.out" 2>&1
# Held until the robot has stood still long enough to judge (the check itself is the state).
wait_for 60 "the operator stop to hold the robot still" "$CHECK" held "$live" operator_stop
"$AGVCAL" stop --release >>"$TMP/live.out" 2>&1
# Released: its HEARTBEAT says it runs again, and the check finds it drove on.
driven_on() { beat_now "$live" commander "^running" && "$CHECK" held "$live" operator_stop; }
wait_for 60 "the commander to drive on after the release" driven_on
kill -KILL $commander
wait_for 60 "the robot to come to rest after the commander died" "$CHECK" halted "$live"
stop $sim agvcal-sim
stop_logger "$live"
grep -q "operator stop from agvcal stop: e2e test" "$TMP/commander.err" && pass "the commander heard the stop" \
  || fail "stop not heard: $(cat "$TMP/commander.err")"
if "$CHECK" limits "$TMP/live.log" "$robot"; then pass "limits never exceeded"; else fail "limits exceeded"; fi
if "$CHECK" held "$TMP/live.log" operator_stop; then pass "operator stop holds the robot until released"; else fail "operator stop"; fi
if "$CHECK" halted "$TMP/live.log"; then pass "killed commander: the robot stops by the command timeout"; else fail "robot did not stop after the commander died"; fi

# 2. Replay: wheel states for 14 s, scans for the first 3 s only.
"$AGVCAL" simulate config/sims/forklift.yaml "$TMP/rec.log" --trajectory demo --quiet
start_logger "$TMP/scans.log" 'DRIVE_CMD|COMMANDER_STATUS|WHEELS'
"$BUILD/agvcal-commander" $robot --trajectory default 2>"$TMP/commander2.err" & commander=$!
if wait_ready "$TMP/scans.log" commander; then
  timeout 3 lcm-logplayer -s 2 -e '^SCAN$' "$TMP/rec.log" >/dev/null 2>&1 &
  timeout 60 lcm-logplayer -s 2 -e '^WHEELS$' "$TMP/rec.log" >/dev/null 2>&1
fi
stop $commander agvcal-commander
stop_logger "$TMP/scans.log"
grep -q "no SCAN for" "$TMP/commander2.err" && pass "the commander names the stale scans" \
  || fail "no message on stale scans: $(cat "$TMP/commander2.err")"
if "$CHECK" held "$TMP/scans.log" stale_inputs WHEELS; then pass "stale scans stop the robot while wheel states still come"; else fail "stale scans"; fi

expect_status 0 "agvcal stop --help" "$AGVCAL" stop --help
expect_status 2 "agvcal stop with an unknown option" "$AGVCAL" stop --now
expect_status 2 "commander: heartbeat timeout below a beat" "$BUILD/agvcal-commander" $robot --heartbeat-timeout 1
no_orphans
finish
