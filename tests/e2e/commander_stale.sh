#!/usr/bin/env bash
# The commander stops the robot when its inputs go stale: wheel states are
# replayed for a while and then cease; the commander must report stale inputs
# and send stop commands (in a private network namespace).
source "$(dirname "$0")/lib.bash" "$@"
"$AGVCAL" simulate config/sims/diff_robot.yaml "$TMP/wheels.log" --trajectory demo --quiet
cat >"$TMP/run.sh" <<SCRIPT
lcm-logger -f -c 'DRIVE_CMD|COMMANDER_STATUS' "$TMP/commands.log" >/dev/null 2>&1 & logger=\$!
"$BUILD/agvcal-commander" config/robots/diff_robot.yaml --trajectory default --stale-timeout 0.5 & commander=\$!
sleep 0.5
lcm-logplayer -s 4 -e '^(WHEELS|SCAN)\$' "$TMP/wheels.log" >/dev/null 2>&1   # about 7 s of wheel states, then silence
sleep 2
kill -INT \$commander; wait \$commander; echo "commander exit \$?"
sleep 0.5; kill -INT \$logger; wait \$logger
SCRIPT
timeout 60 scripts/netns-run bash "$TMP/run.sh" >"$TMP/out" 2>&1
grep -q "commander exit 0" "$TMP/out" && pass "commander exits 0 on SIGINT" || fail "commander exit: $(tail -3 "$TMP/out")"
if "$CHECK" stale "$TMP/commands.log"; then pass "stale inputs stop the robot"; else fail "stale inputs did not stop the robot"; fi
no_orphans
finish
