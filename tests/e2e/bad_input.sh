#!/usr/bin/env bash
# Bad input gets one clear line naming the file, the place and the problem,
# and exit status 2 (spec/cli.md); nothing is written half.
source "$(dirname "$0")/lib.bash" "$@"
"$AGVCAL" simulate config/sims/diff_robot.yaml "$TMP/good.log" --trajectory demo --quiet
size=$(stat -c %s "$TMP/good.log")

head -c $((size / 2)) "$TMP/good.log" >"$TMP/truncated.log"
expect_status 2 "truncated log" "$AGVCAL" info "$TMP/truncated.log"
stderr_has "truncated.log"; stderr_has "cut short"

cp "$TMP/good.log" "$TMP/corrupt.log"
printf '\x00\x00\x00\x00' | dd of="$TMP/corrupt.log" bs=1 seek=50000 conv=notrunc status=none
expect_status 2 "corrupt log" "$AGVCAL" info "$TMP/corrupt.log"
stderr_has "corrupt.log"; stderr_has "byte"

expect_status 2 "missing log" "$AGVCAL" info "$TMP/nothing.log"
stderr_has "nothing.log"

sed 's/track:/trak:/' config/robots/diff_robot.yaml >"$TMP/typo_robot.yaml"
sed "s|../robots/diff_robot.yaml|$TMP/typo_robot.yaml|" config/sims/diff_robot.yaml >"$TMP/typo_sim.yaml"
expect_status 2 "robot file with a typo" "$AGVCAL" simulate "$TMP/typo_sim.yaml" "$TMP/out.log"
stderr_has "typo_robot.yaml"; stderr_has "line 9"; stderr_has "did you mean track"
[ -e "$TMP/out.log" ] || [ -e "$TMP/out.log.partial" ] && fail "a result file was left" || pass "no result file written"

sed 's/ticks_per_rev/ticks_per_revolution/' config/sims/diff_robot.yaml >"$TMP/typo_sim2.yaml"
sed -i "s|../robots/|$SRC/config/robots/|" "$TMP/typo_sim2.yaml"
expect_status 2 "simulation config with a typo" "$AGVCAL" simulate "$TMP/typo_sim2.yaml" "$TMP/out.log"
stderr_has "sensors.wheels.ticks_per_revolution"

expect_status 2 "unknown trajectory" "$AGVCAL" simulate config/sims/diff_robot.yaml "$TMP/out.log" --trajectory zigzag
stderr_has "zigzag"
expect_status 2 "unknown option" "$AGVCAL" simulate config/sims/diff_robot.yaml "$TMP/out.log" --sped 3
expect_status 2 "group without a source" scripts/agvcal-group
expect_status 2 "group with a missing recording" scripts/agvcal-group --replay "$TMP/nothing.log"
touch "$TMP/exists.log"
expect_status 2 "group never overwrites a recording" scripts/agvcal-group --replay logs/forklift_demo.log --log "$TMP/exists.log"
stderr_has "exists.log"
expect_status 2 "group: a commander needs a robot, not a replay" scripts/agvcal-group --replay logs/forklift_demo.log --commander
expect_status 2 "group: bad --process" scripts/agvcal-group --robot config/robots/forklift.yaml --process 'no command'
for cmd in "$AGVCAL" "$BUILD/agvcal-sim" "$BUILD/agvcal-commander" scripts/agvcal-group; do
  expect_status 0 "$(basename "$cmd") --help" "$cmd" --help
done
expect_status 0 "agvcal simulate --help" "$AGVCAL" simulate --help
finish
