#!/usr/bin/env bash
# The 3D-lidar ground calibration end to end: `agvcal ground` on a recording,
# a KITTI frame and bad input, with the exit statuses of spec/cli.md (0 / 2 / 3)
# and no partial result file; and agvcal-ground giving the same result through
# LCM's file:// provider and live through lcm-logplayer (private network namespace).
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
GROUND=$BUILD/agvcal-ground
sim_config() {  # sim_config PITCH OUT [START_UTIME]: the forklift standing or driving, its 3D lidar on
  cat >"$2" <<EOF
robot: $SRC/config/robots/forklift.yaml
start_utime: ${3:-1700000000000000}
truth:
  lidar3d: {z: 1.912, pitch: $1, roll: -0.012}
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 0}
  lidar3d: {rate: 10, rings: 16, points_per_ring: 360, body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]}}
EOF
}
same_result() {  # same_result A.json B.json: equal but for the source lines and the provenance
  diff <(python3 tests/tools/without_provenance.py "$1" | grep -v '"kind"\|"path"') \
       <(python3 tests/tools/without_provenance.py "$2" | grep -v '"kind"\|"path"') >/dev/null
}
sim_config 0.035 "$TMP/sim3d.yaml"
"$AGVCAL" simulate "$TMP/sim3d.yaml" "$TMP/clouds.log" --trajectory demo --quiet

# A recording: exit 0, RESULT.json with the keys of spec/cli.md.
expect_status 0 "ground on a recording" "$AGVCAL" ground $robot "$TMP/clouds.log" --out "$TMP/offline.json"
for key in '"lidar3d"' '"frames"' '"inliers"' '"grid"' '"std"' '"value"'; do
  grep -qF "$key" "$TMP/offline.json" && pass "RESULT.json has $key" || fail "RESULT.json lacks $key"
done
grep -qF "grid search (accepted" "$TMP/stdout" && pass "both estimates printed" || fail "no grid column: $(cat "$TMP/stdout")"

# The same numbers through agvcal-ground reading the log with LCM's file:// provider.
expect_status 0 "agvcal-ground through file://" \
  timeout 120 "$GROUND" $robot --grid --out "$TMP/file.json" --lcm-url "file://$TMP/clouds.log?speed=0"
same_result "$TMP/offline.json" "$TMP/file.json" && pass "file:// result identical" || fail "file:// result differs"

# Live: lcm-logplayer feeds agvcal-ground; GROUND_ESTIMATE and HEARTBEAT are recorded.
start_logger "$TMP/estimates.log" GROUND_ESTIMATE
"$GROUND" $robot --grid --out "$TMP/live.json" & ground=$!
wait_ready "$TMP/estimates.log" ground && timeout 120 lcm-logplayer -s 2 "$TMP/clouds.log"
stop $ground agvcal-ground; status=$?
stop_logger "$TMP/estimates.log"
[ $status -eq 0 ] && pass "agvcal-ground live, fed by lcm-logplayer (exit 0)" || fail "agvcal-ground live: exit $status"
same_result "$TMP/offline.json" "$TMP/live.json" && pass "live result identical to offline" \
  || fail "live result differs from offline (a cloud lost on the bus?): $(grep '"frames' "$TMP/live.json" | tr -d '\n')"
clouds=$("$AGVCAL" info "$TMP/clouds.log" --json | grep -A2 '"CLOUD"' | grep -o '"count": [0-9]*' | grep -o '[0-9]*')
estimates=$("$AGVCAL" info "$TMP/estimates.log" --json | grep -A2 '"GROUND_ESTIMATE"' | grep -o '"count": [0-9]*' | grep -o '[0-9]*')
[ -n "$clouds" ] && [ "$clouds" = "$estimates" ] && pass "one GROUND_ESTIMATE per cloud ($clouds)" \
  || fail "GROUND_ESTIMATE count '$estimates', clouds '$clouds'"
beat_seen "$TMP/estimates.log" ground && pass "heartbeat published" || fail "no heartbeat"

# A KITTI frame.
kitti=$SRC/../shared/data/kitti-velodyne-frames/raw_frame/000000.bin
if [ -r "$kitti" ]; then
  expect_status 0 "ground on a KITTI frame" "$AGVCAL" ground config/robots/kitti_hdl64e.yaml "$kitti" --out "$TMP/kitti.json"
  grep -qF '"kind": "kitti"' "$TMP/kitti.json" && pass "KITTI result written" || fail "no KITTI result"
  head -c 1000 "$kitti" >"$TMP/cut.bin"
  expect_status 2 "truncated KITTI frame" "$AGVCAL" ground config/robots/kitti_hdl64e.yaml "$TMP/cut.bin" --out "$TMP/cut.json"
  stderr_has "cut.bin"; stderr_has "byte 992"; stderr_has "truncated record"
  [ -e "$TMP/cut.json" ] && fail "a result file was written" || pass "no result file for bad input"
fi

# Bad input: exit 2 naming file, place and problem.
printf 'VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\nDATA ascii\n1 2 3\n4 five 6\n' >"$TMP/bad.pcd"
expect_status 2 "malformed PCD" "$AGVCAL" ground $robot "$TMP/bad.pcd"
stderr_has "bad.pcd"; stderr_has "line 9"; stderr_has "expected 3 numbers per point"
expect_status 2 "a recording without clouds" "$AGVCAL" ground $robot logs/forklift_demo.log
stderr_has "no messages on channel CLOUD"
expect_status 2 "a robot without a 3D lidar" "$AGVCAL" ground config/robots/diff_robot.yaml "$TMP/clouds.log"
stderr_has "diff_robot.yaml"; stderr_has "no 3D lidar"
expect_status 2 "a missing options file" "$AGVCAL" ground $robot "$TMP/clouds.log" --config "$TMP/none.yaml"
stderr_has "none.yaml"

# The floor cannot determine the answer: exit 3, no result file.
{
  printf 'VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 720\nHEIGHT 1\nDATA ascii\n'
  for i in $(seq 0 719); do echo "$i" | awk '{a = $1 * 3.14159265 / 360; printf "%.3f %.3f %.3f\n", 6*cos(a), 6*sin(a), ($1 % 30) / 10.0 - 1.2}'; done
} >"$TMP/walls.pcd"
expect_status 3 "no floor in view" "$AGVCAL" ground $robot "$TMP/walls.pcd" --out "$TMP/walls.json"
stderr_has "cannot determine"; stderr_has "not visible enough"
[ -e "$TMP/walls.json" ] || compgen -G "$TMP/walls.json*.partial" >/dev/null && fail "a result file was left" || pass "no result file when refused"
# The robot drives onto a ramp halfway: the lidar's pitch against the floor changes by 1.4 deg.
# (the second half recorded after the first, 1000 s later: a recording's stamps go forward)
sim_config 0.06 "$TMP/ramp.yaml" 1700001000000000
"$AGVCAL" simulate "$TMP/ramp.yaml" "$TMP/ramp_half.log" --trajectory demo --quiet
cat "$TMP/clouds.log" "$TMP/ramp_half.log" >"$TMP/ramp.log"
# Concatenated as recorded (the second half's stamps start again): its clouds are out of order,
# left out and said, never silently.
cat "$TMP/clouds.log" "$TMP/clouds.log" >"$TMP/twice.log"
"$AGVCAL" ground $robot "$TMP/twice.log" >/dev/null 2>"$TMP/twice.err"
grep -q "left out: .*(CLOUD)" "$TMP/twice.err" && pass "clouds out of order are said" ||
  fail "clouds out of order left out without a word: $(head -3 "$TMP/twice.err")"
expect_status 3 "a floor that tilts between frames" "$AGVCAL" ground $robot "$TMP/ramp.log"
stderr_has "not one level plane across frames"; stderr_has "slope"

# A lidar turning on its mount: a table of 24 sectors; a part turn is refused naming the sectors.
cat >"$TMP/turret_robot.yaml" <<EOF
name: turret-agv
drive: differential
wheels: {left: left_wheel, right: right_wheel}
params: {left_radius: 0.075, right_radius: 0.075, track: 0.45}
lidar3d: {channel: CLOUD, z: 1.20, body: {min: [-0.4, -0.35, 0.0], max: [0.4, 0.35, 1.0]},
          rotation: {channel: LIDAR3D_ANGLE, sector_width: 0.2617993878}}
limits: {max_speed: 0.8, max_omega: 1.0, max_accel: 0.5}
EOF
turret_sim() {  # turret_sim SPEED OUT.log
  cat >"$TMP/turret_sim.yaml" <<EOF
robot: $TMP/turret_robot.yaml
truth:
  lidar3d: {z: 1.215, pitch: 0.02, roll: 0.01}
sensors:
  lidar3d: {rate: 10, rings: 16, points_per_ring: 360, body: {min: [-0.4, -0.35, 0.0], max: [0.4, 0.35, 1.0]},
            turret: {rate: 40, speed: $1, axis_pitch: 0.01, axis_roll: -0.005}}
EOF
  "$AGVCAL" simulate "$TMP/turret_sim.yaml" "$2" --trajectory demo --quiet
}
turret_sim 0.5 "$TMP/turret.log"
expect_status 0 "ground for a turning lidar" "$AGVCAL" ground "$TMP/turret_robot.yaml" "$TMP/turret.log" --out "$TMP/turret.json"
sectors=$(grep -c '"angle_mean"' "$TMP/turret.json")
[ "$sectors" = 24 ] && pass "24 sectors in RESULT.json" || fail "$sectors sectors in RESULT.json"
expect_status 0 "agvcal-ground for a turning lidar through file://" \
  timeout 120 "$GROUND" "$TMP/turret_robot.yaml" --grid --out "$TMP/turret_file.json" --lcm-url "file://$TMP/turret.log?speed=0"
same_result "$TMP/turret.json" "$TMP/turret_file.json" && pass "turning lidar: file:// result identical" \
  || fail "turning lidar: file:// result differs"
turret_sim 0.1 "$TMP/part_turn.log"
expect_status 3 "a part turn" "$AGVCAL" ground "$TMP/turret_robot.yaml" "$TMP/part_turn.log"
stderr_has "no estimate for sector"; stderr_has "turn the lidar through every sector"

expect_status 0 "agvcal ground --help" "$AGVCAL" ground --help
expect_status 0 "agvcal-ground --help" "$GROUND" --help
expect_status 2 "agvcal-ground with a bad window" "$GROUND" $robot --window 0
left=$(test_pgrep "$GROUND")
[ -z "$left" ] && pass "no agvcal-ground left behind" || { fail "agvcal-ground left behind: $left"; kill -9 $left; }
no_orphans
finish
