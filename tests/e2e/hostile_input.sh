#!/usr/bin/env bash
# Hostile input that decodes: a recording with one impossible value must not give a silently
# wrong or silently thinned result (issue 17). What is left out is named (event, channel,
# wheel, size) on stderr and in RESULT.json's input.notes, and nothing else goes with it.
source "$(dirname "$0")/lib.bash" "$@"
wheel_log=tests/tools/wheel_log.py
robot=config/robots/forklift.yaml log=logs/forklift_demo.log
json() { python3 -c "import json, sys; r = json.load(open(sys.argv[1])); print($2)" "$1"; }

expect_status 0 "clean sample" "$AGVCAL" solve $robot $log --quiet --out "$TMP/clean.json"
if [ -s "$TMP/stderr" ]; then fail "clean sample says: $(head -c 300 "$TMP/stderr")"; else pass "clean sample: nothing left out"; fi

# Item 2: one WHEELS sample whose drive wheel jumps +100 / +1000 rad (a flipped bit).
for jump in 100 1000; do
  python3 $wheel_log $log "$TMP/jump.log" 2700 position drive $jump
  expect_status 0 "solve: drive wheel +$jump rad in one sample" "$AGVCAL" solve $robot "$TMP/jump.log" --quiet --out "$TMP/jump.json"
  stderr_has "jump.log: event 11875 (WHEELS): wheel 'drive' position jumps +"
  stderr_has "limits.max_speed / radius): dropped"
  stderr_has "1 message(s) of $TMP/jump.log left out"
  dropped=$(json "$TMP/jump.json" "r['input']['dropped']")
  [ "$dropped" = 1 ] && pass "RESULT.json input.dropped 1" || fail "RESULT.json input.dropped '$dropped'"
  # The jump is kept out of the fit: every parameter within 0.2 sigma of the clean recording's.
  off=$(python3 -c "
import json, sys
a, b = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
print(max(abs(a['params'][k]['value'] - b['params'][k]['value']) / a['params'][k]['std'] for k in a['params']))" \
    "$TMP/clean.json" "$TMP/jump.json")
  python3 -c "import sys; sys.exit(not float(sys.argv[1]) < 0.2)" "$off" && pass "+$jump rad: params within $off sigma" ||
    fail "+$jump rad: params off by $off sigma"
done

# Item 3: one flipped bit in one WHEELS utime (+8.4 s) costs that sample alone.
python3 $wheel_log $log "$TMP/stamp.log" 1000 utime 8388608
expect_status 0 "solve: one WHEELS stamp +8.4 s" "$AGVCAL" solve $robot "$TMP/stamp.log" --quiet --out "$TMP/stamp.json"
stderr_has "stamp.log: event 4395 (WHEELS): stamp 8.39"
stderr_has "dropped alone"
for key in "r['residual']['intervals']" "r['input']['dropped'] if 'input' in r else 0"; do
  got=$(json "$TMP/stamp.json" "$key") want=$(json "$TMP/clean.json" "$key")
  [ "$key" = "${key#r\[\'input}" ] || want=1
  [ "$got" = "$want" ] && pass "+8.4 s stamp: $key = $got" || fail "+8.4 s stamp: $key = $got, expected $want"
done

# Item 9: messages that name the real problem.
sed 's/drive_radius: *[0-9.]*/drive_radius: 1e308/' $robot >"$TMP/huge_radius.yaml"
grep -q "drive_radius: 1e308" "$TMP/huge_radius.yaml" || fail "test robot file not made"
expect_status 2 "robot file: drive_radius 1e308" "$AGVCAL" solve "$TMP/huge_radius.yaml" $log --quiet
stderr_has "huge_radius.yaml"; stderr_has "params.drive_radius"; stderr_has "must be from 0.001 to 100 m"
sed 's/^lidar2d: {channel: SCAN/lidar2d: {channel: NOPE/' $robot >"$TMP/nope.yaml"
grep -q "channel: NOPE" "$TMP/nope.yaml" || fail "test robot file not made"
expect_status 2 "robot file: lidar2d channel NOPE" "$AGVCAL" solve "$TMP/nope.yaml" $log --quiet
stderr_has "NOPE"
if grep -q "differential" "$TMP/stderr"; then fail "blames the IMU: $(cat "$TMP/stderr")"; else pass "does not blame the IMU"; fi
# A clean dual-steer recording too short for the diagnosis: exit 3 (too little data), not 2.
python3 - logs/dual_steer_demo.log "$TMP/short.log" <<'PY'
import struct, sys
data = open(sys.argv[1], 'rb').read()
pos = 0
while pos < 0.8 * len(data):
    _, _, _, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
    pos += 28 + channel_len + data_len
open(sys.argv[2], 'wb').write(data[:pos])
PY
expect_status 3 "diagnose: a short clean dual-steer recording" "$AGVCAL" diagnose config/robots/dual_steer_agv.yaml "$TMP/short.log" --quiet
stderr_has "short.log"; stderr_has "usable intervals"; stderr_has "needs at least 40"

# Two clocks in one recording (issue 17 item 8): every SCAN stamped an hour after the wheels.
python3 tests/tools/corrupt_log.py $log "$TMP/clocks.log" SCAN all 8 +3600000000
expect_status 2 "solve: scans on another clock than the wheels" "$AGVCAL" solve $robot "$TMP/clocks.log" --quiet
stderr_has "clocks.log: scan and wheel stamps are 3600 s apart"; stderr_has "two clock domains"

# Every class of bench/hostile_inputs.py (stamps and values of every stream, torn and appended
# recordings, channel names, robot-file values and sizes, FIFOs, devices, pipes): each one's
# documented exit status and its cause named; crash, hang, silently wrong, partial, unclear: 0.
if python3 bench/hostile_inputs.py --bin "$BUILD" >"$TMP/hostile.txt" 2>&1; then
  pass "hostile inputs: $(tail -1 "$TMP/hostile.txt")"
else
  fail "hostile inputs: $(grep -v '^ok\|^ ' "$TMP/hostile.txt" | head -c 2000)"
fi

finish
