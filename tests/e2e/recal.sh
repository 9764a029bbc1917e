#!/usr/bin/env bash
# Recalibration during normal operation (docs/recalibration.md): the forklift drives its work
# route (commander trajectory "route", simulated offline); `agvcal recal` collects the route's
# zone passes and decides twice: the first candidate is accepted (much better on held-out
# segments, consistent with the nominal values' prior), the second is rejected (not
# significantly better than the calibration then in use). The recording replayed with
# lcm-logplayer into agvcal-scanmatch + agvcal-recal (private network namespace) makes the
# same decisions, byte for byte, and writes the same robot file. A restart goes on from the
# accepted robot file. Bad input exits 2.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift_nav.yaml
config=config/recal.yaml
log=$TMP/route.log

expect_status 0 "simulate the forklift's work route" "$AGVCAL" simulate config/sims/forklift_route.yaml "$log" --trajectory route

# Offline.
expect_status 0 "agvcal recal on the recording" "$AGVCAL" recal "$robot" "$log" --config "$config" \
  --out-robot "$TMP/offline.yaml" --decisions "$TMP/offline.jsonl"
cp "$TMP/stdout" "$TMP/offline.out"
cat "$TMP/offline.out"
python3 - "$TMP/offline.jsonl" "$TMP/offline.yaml" <<'PY' && pass "offline decisions: accepted then rejected, calibration near the truth" || fail "offline decisions"
import json, sys, re
lines = open(sys.argv[1]).read().splitlines()
d = [json.loads(l) for l in lines]
assert [x["verdict"] for x in d] == ["accepted", "rejected"], [x["verdict"] for x in d]
assert d[0]["improvement"]["relative"] > 0.8 and d[0]["improvement"]["p"] < 0.05, d[0]["improvement"]
assert d[0]["consistency"]["consistent"], d[0]["consistency"]
assert not d[1]["improvement"]["significant"], d[1]["improvement"]
assert len(d[0]["segments"]["heldout"]) == 4 and len(d[0]["segments"]["fit"]) == 8
# Simulator truth (config/sims/forklift_route.yaml); tolerances about 5 sigma of the fit.
truth = {"drive_radius": (0.1163, 0.0004), "wheelbase": (1.4335, 0.005), "steer_offset": (0.0131, 0.0005),
         "lidar2d.x": (1.6152, 0.015), "lidar2d.y": (0.0123, 0.003), "lidar2d.yaw": (-0.0142, 0.002)}
for name, (value, tol) in truth.items():
    got = d[0]["candidate"][name]["value"]
    assert abs(got - value) < tol, (name, got, value)
text = open(sys.argv[2]).read()
# The robot file holds the candidate rounded to its sigma, and the run goes on from exactly
# what the file holds (as a restart from it does).
written = re.search(r"drive_radius: ([0-9.e-]+)", text).group(1)
radius, decimals = float(written), len(written.split(".")[1])
assert abs(radius - d[0]["candidate"]["drive_radius"]["value"]) <= 0.5 * 10 ** -decimals + 1e-15, written
assert d[1]["in_use"]["drive_radius"]["value"] == radius, (d[1]["in_use"]["drive_radius"], radius)
PY

# Live: the same recording through the bus.
start_logger "$TMP/beats.log" HEARTBEAT
"$BUILD/agvcal-scanmatch" "$robot" 2> "$TMP/scanmatch.err" & matcher=$!
"$BUILD/agvcal-recal" "$robot" --config "$config" --out-robot "$TMP/live.yaml" \
  --decisions "$TMP/live.jsonl" 2> "$TMP/recal.err" & recal=$!
# 8x: agvcal-recal gives up waiting for a segment's last scan matches 30 s of robot time after
# it ends (kLookbackS), 3.75 s of wall time here; a scan matcher slowed that much by a loaded
# machine would otherwise change a segment's data.
wait_ready "$TMP/beats.log" scanmatch recal && timeout 180 lcm-logplayer -s 8 "$log"
# SIGINT: a decision under way is finished and written first.
stop $recal agvcal-recal; status=$?
stop $matcher agvcal-scanmatch
stop_logger "$TMP/beats.log"
[ $status -eq 0 ] && pass "replay into agvcal-scanmatch + agvcal-recal, stopped with SIGINT (exit 0)" ||
  fail "agvcal-recal exit $status: $(tail -c 400 "$TMP/recal.err")"
# Every message of the recording arrived (LCM drops what a busy process has not taken from
# its queue unless the subscription keeps everything: BusSource).
counts=$("$AGVCAL" info "$log" | awk '$1 == "WHEELS" || $1 == "SCAN" || $1 == "POSE" {printf "%s=%s ", $1, $3}')
wheels=$(sed -n 's/.*WHEELS=\([0-9]*\).*/\1/p' <<< "$counts"); scans=$(sed -n 's/.*SCAN=\([0-9]*\).*/\1/p' <<< "$counts")
poses=$(sed -n 's/.*POSE=\([0-9]*\).*/\1/p' <<< "$counts")
if grep -qF "received $scans scans and $wheels wheel states" "$TMP/scanmatch.err" &&
   grep -qE "received $wheels wheel states, [0-9]+ scan matches, $poses poses" "$TMP/recal.err"; then
  pass "the live processes received every message of the recording ($counts)"
else fail "messages lost (recording: $counts): $(tail -1 "$TMP/scanmatch.err"); $(tail -1 "$TMP/recal.err")"; fi
if cmp -s "$TMP/offline.jsonl" "$TMP/live.jsonl"; then pass "live decisions identical to offline"
else fail "live decisions differ: $(diff <(cut -c1-300 "$TMP/offline.jsonl") <(cut -c1-300 "$TMP/live.jsonl" 2>&1) | head -5); $(tail -1 "$TMP/recal.err"); $(tail -1 "$TMP/scanmatch.err")"; fi
# Identical but for the provenance lines (the command and the date are each run's own).
if diff <(python3 tests/tools/without_provenance.py "$TMP/offline.yaml") \
        <(python3 tests/tools/without_provenance.py "$TMP/live.yaml") > "$TMP/robot.diff"; then
  pass "live robot file identical to offline (but for its provenance)"
else fail "live robot file differs: $(head -5 "$TMP/robot.diff")"; fi
if ls "$TMP"/*.partial >/dev/null 2>&1; then fail "partial files left"; else pass "no partial file left"; fi
left=$(test_pgrep "$BUILD/agvcal-(scanmatch|recal)|lcm-logplayer -s [0-9]+ $log")
if [ -z "$left" ]; then pass "no process left behind"; else fail "left behind: $left"; fi

# A restart goes on from the accepted robot file (its std: as the uncertainty in use).
expect_status 0 "restart from the accepted calibration" "$AGVCAL" recal "$robot" "$log" --config "$config" \
  --out-robot "$TMP/offline.yaml" --decisions "$TMP/restart.jsonl"
if grep -qF "calibration in use: $TMP/offline.yaml (std:)" "$TMP/stdout"; then pass "starts from the accepted file"
else fail "did not start from the accepted file: $(head -2 "$TMP/stdout")"; fi
python3 - "$TMP/restart.jsonl" <<'PY' && pass "restart: nothing better than the recalibrated values" || fail "restart decisions"
import json, sys
d = [json.loads(l) for l in open(sys.argv[1])]
assert [x["verdict"] for x in d] == ["rejected", "rejected"], [x["verdict"] for x in d]
PY

# Odometry distance windows instead of zones (no POSE needed): 4 m in every 9 m driven.
cat > "$TMP/windows.yaml" <<'YAML'
distance_windows: {start_m: 1, length_m: 4, period_m: 9}
prior_std:
  params: {drive_radius: 0.003, wheelbase: 0.03, steer_offset: 0.03}
  lidar2d: {x: 0.03, y: 0.03, yaw: 0.03}
YAML
expect_status 0 "agvcal recal with distance windows" "$AGVCAL" recal "$robot" "$log" --config "$TMP/windows.yaml" \
  --decisions "$TMP/windows.jsonl"
python3 - "$TMP/windows.jsonl" <<'PY' && pass "distance windows: accepted, segments named by window" || fail "distance windows: $(cat "$TMP/stdout")"
import json, sys
d = [json.loads(l) for l in open(sys.argv[1])]
assert [x["verdict"] for x in d] == ["accepted"], [x["verdict"] for x in d]
assert d[0]["segments"]["fit"][0]["trigger"] == "window 0"
assert all(abs(s["distance_m"] - 4.0) < 0.05 for s in d[0]["segments"]["fit"]), d[0]["segments"]["fit"]
assert abs(d[0]["candidate"]["drive_radius"]["value"] - 0.1163) < 0.0004
PY

# Bad input.
printf 'zones:\n  - {name: a, circle: {x: 0, y: 0, radius: 1}}\ndecision: {segmnts: 12}\n' > "$TMP/typo.yaml"
expect_status 2 "config with a typo" "$AGVCAL" recal "$robot" "$log" --config "$TMP/typo.yaml"
stderr_has "typo.yaml"
stderr_has "segmnts"
expect_status 2 "missing --config" "$BUILD/agvcal-recal" "$robot"
stderr_has "--config"
grep -v '^lidar2d:' "$robot" > "$TMP/no_lidar.yaml"
expect_status 2 "robot without the mount to calibrate" "$AGVCAL" recal "$TMP/no_lidar.yaml" "$log" --config "$config" --source lidar2d
stderr_has "lidar2d"
expect_status 0 "--help" "$BUILD/agvcal-recal" --help
expect_status 0 "agvcal recal --help" "$AGVCAL" recal --help
finish
