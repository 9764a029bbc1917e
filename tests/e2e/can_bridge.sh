#!/usr/bin/env bash
# The encoder bridge replays a candump log made from the sample recording's
# wheel states (SYNC + TPDOs of config/bridges/forklift_can.yaml, arrivals up to
# 2 ms late): the WHEELS it publishes equal the recording's (positions and
# steer exactly, velocity within one increment/s, stamps within 50 us after
# 10 s), as fast as possible through LCM's file provider and in real time (x4)
# on the bus in a private network namespace.
# Bad config, candump line and interface exit 2.
source "$(dirname "$0")/lib.bash" "$@"
log=logs/forklift_demo.log
config=config/bridges/forklift_can.yaml
bridge=$BUILD/agvcal-canbridge

"$BUILD/tests/bridge_check" candump "$config" "$log" "$TMP/forklift.candump" 2 >/dev/null
expect_status 0 "replay as fast as possible into file://" \
  "$bridge" "$config" --robot config/robots/forklift.yaml --candump "$TMP/forklift.candump" --speed 0 --lcm-url "file://$TMP/fast.log?mode=w"
stderr_has "2901 wheel states, 2901 SYNCs (0 lost), 0 incomplete cycles"
if "$BUILD/tests/bridge_check" wheels "$log" "$TMP/fast.log" 10 50; then
  pass "wheel states equal the recording's"
else
  fail "wheel states differ from the recording's"
fi

start_logger "$TMP/live.log" WHEELS
expect_status 0 "replay at x4 on the bus" timeout 120 "$bridge" "$config" --candump "$TMP/forklift.candump" --speed 4
stop_logger "$TMP/live.log"
if "$BUILD/tests/bridge_check" wheels "$log" "$TMP/live.log" 10 50 >/dev/null; then
  pass "the bus carried the same wheel states"
else
  fail "the bus carried different wheel states"
fi

# Bad input.
sed 's/ticks_per_rev: 4096/ticks_per_revv: 4096/' "$config" > "$TMP/typo.yaml"
expect_status 2 "config with a typo" "$bridge" "$TMP/typo.yaml" --candump "$TMP/forklift.candump"
stderr_has "typo.yaml: line 11, key wheels.drive.position.ticks_per_revv: unknown key (did you mean ticks_per_rev?)"
head -100 "$TMP/forklift.candump" > "$TMP/bad.candump"
echo "(1700000001.000000) can0 181#0011" >> "$TMP/bad.candump"
expect_status 2 "a PDO too short for its layout" "$bridge" "$config" --candump "$TMP/bad.candump" --speed 0 \
  --lcm-url "file://$TMP/bad.log?mode=w"
stderr_has "bad.candump: line 101: PDO 181 has 2 data bytes"
echo "(1700000001.000000) can0 181##10011" > "$TMP/fd.candump"
expect_status 2 "a CAN FD line" "$bridge" "$config" --candump "$TMP/fd.candump" --lcm-url "file://$TMP/bad.log?mode=w"
stderr_has "fd.candump: line 1: CAN FD frame"
expect_status 2 "no such interface" timeout 20 scripts/netns-run "$bridge" "$config" --can nosuchcan0
stderr_has "--can nosuchcan0: "   # no such interface (or no CAN support in the kernel)
expect_status 2 "config without the robot's wheels" "$bridge" config/bridges/diff_robot_can.yaml \
  --robot config/robots/forklift.yaml --candump "$TMP/forklift.candump"
stderr_has "diff_robot_can.yaml: wheels: no wheel 'drive' (role drive in config/robots/forklift.yaml)"
expect_status 2 "both sources" "$bridge" "$config" --can can0 --candump "$TMP/forklift.candump"
expect_status 0 "--help" "$bridge" --help
finish
