#!/usr/bin/env bash
# `agvcal solve` end to end, and the live solver giving its numbers: a recording
# replayed with lcm-logplayer into agvcal-scanmatch + agvcal-solver (in a private
# network namespace; the solver's final solve matches the scans again from the recording
# an lcm-logger writes) ends with the RESULT.json `agvcal solve` writes for it, value
# for value. Bad input exits 2, a straight-only recording exits 3.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log

expect_status 0 "agvcal solve on the sample" \
  "$BUILD/agvcal" solve "$robot" "$log" --quiet --out "$TMP/offline.json" --write-robot "$TMP/cal.yaml"
expect_status 0 "the calibrated robot file reads back" "$BUILD/agvcal" solve "$TMP/cal.yaml" "$log" --quiet
python3 - "$TMP/offline.json" <<'PY' && pass "RESULT.json has the keys of spec/cli.md" || fail "RESULT.json keys"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["drive"] == "tricycle"
assert set(r["params"]) == {"drive_radius", "wheelbase", "steer_offset"}
for k in ("x", "y", "yaw", "time_offset"): assert "value" in r["lidar2d"][k] and "std" in r["lidar2d"][k]
for k in ("intervals", "outliers", "rms_x", "rms_y", "rms_yaw"): assert k in r["residual"]
assert "condition" in r["observability"] and "weak" in r["observability"]
PY

# The solver's final solve matches the scans a second time, from the recording it catches up
# from (calib::SolveAgainDeskewed), as in the group: an lcm-logger writes that recording.
start_logger "$TMP/recording.log" ".*"
"$BUILD/agvcal-scanmatch" "$robot" 2> "$TMP/scanmatch.err" & matcher=$!
"$BUILD/agvcal-solver" "$robot" --out "$TMP/live.json" --catch-up "$TMP/recording.log" 2> "$TMP/solver.err" & solver=$!
wait_ready "$TMP/recording.log" scanmatch solver && timeout 120 lcm-logplayer -s 4 "$log"
# SIGINT: each handles what it has received first; the matcher's last matches, published
# as it stops, are in the solver's queue when the solver stops.
stop $matcher agvcal-scanmatch
stop $solver agvcal-solver; status=$?
stop_logger "$TMP/recording.log"
[ $status -eq 0 ] && pass "replay into agvcal-scanmatch + agvcal-solver (exit 0)" ||
  fail "agvcal-solver exit $status: $(tail -c 400 "$TMP/solver.err")"
grep -q "agvcal-solver: matching the scans of $TMP/recording.log again" "$TMP/solver.err" &&
  ! grep -q "wheel states, the solver received\|cannot match the scans again" "$TMP/solver.err" &&
  pass "the final solve matched the recorded scans again, on every wheel state the solver received" ||
  fail "no second pass on the solver's data: $(tail -c 400 "$TMP/solver.err")"
python3 - "$TMP/offline.json" "$TMP/live.json" <<'PY' && pass "live result equals agvcal solve's" || fail "live result differs: $(diff "$TMP/offline.json" "$TMP/live.json" | head -20)"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
for k in ("params", "lidar2d", "residual"):
    assert a[k] == b[k], (k, a[k], b[k])
PY

# Refusals.
"$BUILD/agvcal" simulate config/sims/diff_robot.yaml "$TMP/straight.log" --trajectory straight --quiet
expect_status 3 "straight-only recording" "$BUILD/agvcal" solve config/robots/diff_robot.yaml "$TMP/straight.log" --quiet --out "$TMP/no.json"
stderr_has "track"
if [ ! -e "$TMP/no.json" ]; then pass "no result file on exit 3"; else fail "result file written on exit 3"; fi
expect_status 2 "robot file of another drive type" "$BUILD/agvcal" solve config/robots/diff_robot.yaml "$log" --quiet
stderr_has "forklift_demo.log"
head -c 100000 "$log" > "$TMP/truncated.log"
expect_status 2 "truncated log" "$BUILD/agvcal" solve "$robot" "$TMP/truncated.log" --quiet
stderr_has "truncated.log"
expect_status 2 "unknown option" "$BUILD/agvcal" solve "$robot" "$log" --bogus
expect_status 2 "--heldout-windows 0" "$BUILD/agvcal" solve "$robot" "$log" --fit-fraction 0.5 --heldout-windows 0
stderr_has "heldout-windows"

# Held-out comparison: path windows, the sign test, the motion coverage.
expect_status 0 "agvcal solve --fit-fraction 0.5" \
  "$BUILD/agvcal" solve "$robot" "$log" --quiet --fit-fraction 0.5 --out "$TMP/half.json"
python3 - "$TMP/half.json" <<'PY' && pass "held-out: 20 path windows, calibrated better, sign test" || fail "held-out: $(python3 -c "import json,sys; print(json.load(open(sys.argv[1])).get('heldout'))" "$TMP/half.json")"
import json, sys
h = json.load(open(sys.argv[1]))["heldout"]
p = h["paired"]
assert h["calibrated"]["windows"] >= 20 and p["windows"] == h["calibrated"]["windows"], h
assert h["window_m"] > 0 and len(h["nominal"]["per_window_translation_m"]) == p["windows"]
assert p["calibrated_better"] >= 0.8 * p["windows"] and p["sign_test_p"] < 0.01, p
assert h["calibrated"]["error_per_metre"] < h["nominal"]["error_per_metre"]
assert h["motion"]["regressor"] == "steer" and 0 <= h["motion"]["heldout_outside_fit"] <= 1
PY
expect_status 0 "--help" "$BUILD/agvcal" solve --help
expect_status 0 "solver --help" "$BUILD/agvcal-solver" --help
finish
