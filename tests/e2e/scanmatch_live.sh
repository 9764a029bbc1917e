#!/usr/bin/env bash
# The live scan matcher gives the offline numbers: a recording replayed with
# lcm-logplayer into agvcal-scanmatch (in a private network namespace) yields
# SCAN_MATCH messages identical, bit for bit, to the offline pipeline's; SIGINT
# flushes the last match and exits 0; bad input exits 2.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log

# SIGINT: the matcher handles what it has received, publishes its last match and exits.
replay_into "$TMP/live.log" SCAN_MATCH 4 "$SRC/$log" scanmatch "$BUILD/agvcal-scanmatch" "$robot"
if grep -q "agvcal-scanmatch: stopped; received 580 scans and 2901 wheel states" "$TMP/scanmatch.err"; then
  pass "every scan and wheel state received"
else
  fail "messages lost: $(tail -c 400 "$TMP/scanmatch.err")"
fi
if "$CHECK" scanmatch "$log" "$robot" "$TMP/live.log"; then
  pass "live SCAN_MATCH identical to the offline pipeline"
else
  fail "live SCAN_MATCH differs from the offline pipeline"
fi
left=$(test_pgrep "$BUILD/agvcal-scanmatch|lcm-logger -f $TMP|lcm-logplayer")
if [ -z "$left" ]; then pass "no process left behind"; else fail "left behind: $left"; fi

# Bad input: no 2D lidar in the robot file, unreadable file, unknown option.
grep -v '^lidar2d:' "$robot" > "$TMP/no_lidar.yaml"
expect_status 2 "robot without lidar2d" "$BUILD/agvcal-scanmatch" "$TMP/no_lidar.yaml"
stderr_has "no_lidar.yaml"
stderr_has "lidar2d"
expect_status 2 "missing robot file" "$BUILD/agvcal-scanmatch" "$TMP/missing.yaml"
stderr_has "missing.yaml"
expect_status 2 "unknown option" "$BUILD/agvcal-scanmatch" "$robot" --speed 2
expect_status 0 "--help" "$BUILD/agvcal-scanmatch" --help
finish
