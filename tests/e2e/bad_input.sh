#!/usr/bin/env bash
# Bad input gets one clear line naming the file, the place and the problem,
# and exit status 2 (spec/cli.md); nothing is written half.
source "$(dirname "$0")/lib.bash" "$@"
"$AGVCAL" simulate config/sims/diff_robot.yaml "$TMP/good.log" --trajectory demo --quiet
size=$(stat -c %s "$TMP/good.log")

# A log cut short (a killed logger): the torn last event is skipped and named, the events before
# it are kept (docs/bad-input.md); was exit 2.
head -c $((size / 2)) "$TMP/good.log" >"$TMP/truncated.log"
expect_status 0 "truncated log" "$AGVCAL" info "$TMP/truncated.log"
grep -q "^skipped: bytes .* (truncated event (log cut short)" "$TMP/stdout" && pass "the torn last event is named" ||
  fail "the torn last event is not named: $(tail -2 "$TMP/stdout")"

cp "$TMP/good.log" "$TMP/corrupt.log"
printf '\x00\x00\x00\x00' | dd of="$TMP/corrupt.log" bs=1 seek=50000 conv=notrunc status=none
expect_status 2 "corrupt log" "$AGVCAL" info "$TMP/corrupt.log"
stderr_has "corrupt.log"; stderr_has "byte"

expect_status 2 "missing log" "$AGVCAL" info "$TMP/nothing.log"
stderr_has "nothing.log"

# A length field no message can hold is refused before anything is allocated (it took 8 GB and a
# SIGSEGV): nranges of the 20th SCAN (after the hash, utime and six floats), num_wheels of a WHEELS.
corrupt=tests/tools/corrupt_log.py
python3 $corrupt "$TMP/good.log" "$TMP/huge_scan.log" SCAN 20 40 0x7fffffff
for command in info solve diagnose; do
  args=("$TMP/huge_scan.log"); [ $command = info ] || args=(config/robots/diff_robot.yaml "$TMP/huge_scan.log" --quiet)
  expect_status 2 "$command: a scan of 2^31 beams" timeout 20 "$AGVCAL" $command "${args[@]}"
  stderr_has "huge_scan.log"; stderr_has "(SCAN)"; stderr_has "nranges = 2147483647"; stderr_has "are left"
done
python3 $corrupt "$TMP/good.log" "$TMP/huge_wheels.log" WHEELS 5 16 0x10000000
expect_status 2 "solve: 2^28 wheels" timeout 20 "$AGVCAL" solve config/robots/diff_robot.yaml "$TMP/huge_wheels.log" --quiet
stderr_has "(WHEELS)"; stderr_has "num_wheels = 268435456"

sed 's/track:/trak:/' config/robots/diff_robot.yaml >"$TMP/typo_robot.yaml"
sed "s|../robots/diff_robot.yaml|$TMP/typo_robot.yaml|" config/sims/diff_robot.yaml >"$TMP/typo_sim.yaml"
expect_status 2 "robot file with a typo" "$AGVCAL" simulate "$TMP/typo_sim.yaml" "$TMP/out.log"
stderr_has "typo_robot.yaml"; stderr_has "line 9"; stderr_has "did you mean track"
[ -e "$TMP/out.log" ] || compgen -G "$TMP/out.log*.partial" >/dev/null && fail "a result file was left" || pass "no result file written"

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
