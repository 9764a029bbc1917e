#!/usr/bin/env bash
# The ROS result files of `agvcal ground`, `recal` and `solve` for a tricycle (docs/ros.md),
# parsed back (the URDF by liburdfdom, the launch file by xml.etree, YAML by PyYAML) and
# compared with what they must hold: ground's RESULT.json z, pitch, roll and the robot file's
# lidar3d x, y, yaw; the calibration recal accepted (its --out-robot file); solve's RESULT.json
# (tricycle_controller and bicycle_steering_controller). Each names the recording's SHA-256
# and gives sigmas. Bad requests exit 2 before the work, with no file written.
source "$(dirname "$0")/lib.bash" "$@"
check=tests/ros/check_ros_results.py
origin() {  # origin URDF JOINT: liburdfdom's reading of the joint, beside the URDF
  "$BUILD/tests/urdf_joint_origin" "$1" "$2" >"$1.origin" || fail "liburdfdom does not read $1: $(cat "$1")"
}

# ground: a 3D lidar mounted off the base frame's origin, turned (x, y, yaw from the robot file).
sed 's/lidar3d: {channel: CLOUD, z: 1.90, pitch: 0.0, roll: 0.0, x: 0.0, y: 0.0, yaw: 0.0,/lidar3d: {channel: CLOUD, z: 1.90, pitch: 0.0, roll: 0.0, x: 0.4, y: -0.1, yaw: 0.05,/' \
  config/robots/forklift.yaml >"$TMP/forklift3d.yaml"
grep -q "x: 0.4, y: -0.1, yaw: 0.05" "$TMP/forklift3d.yaml" || fail "the robot file's lidar3d line changed: fix the sed above"
cat >"$TMP/sim3d.yaml" <<YAML
robot: $SRC/config/robots/forklift.yaml
start_utime: 1700000000000000
truth:
  lidar3d: {z: 1.912, pitch: 0.035, roll: -0.012}
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 0}
  lidar3d: {rate: 10, rings: 16, points_per_ring: 360, body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]}}
YAML
"$AGVCAL" simulate "$TMP/sim3d.yaml" "$TMP/clouds.log" --trajectory demo --quiet
expect_status 0 "ground, writing URDF, tf and Autoware files" "$AGVCAL" ground "$TMP/forklift3d.yaml" "$TMP/clouds.log" \
  --quiet --out "$TMP/ground.json" --write-urdf "$TMP/ground.urdf" --write-tf "$TMP/ground.launch.xml" \
  --write-autoware "$TMP/sensors_calibration.yaml" --lidar-frame velodyne_top
origin "$TMP/ground.urdf" velodyne_top_joint
python3 - "$TMP/ground.json" >"$TMP/ground.expected.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))["lidar3d"]
print(json.dumps({"x": 0.4, "y": -0.1, "yaw": 0.05, **{k: r[k]["value"] for k in ("z", "pitch", "roll")}}))
PY
if python3 $check mount "$TMP/ground.expected.json" "$TMP/clouds.log" base_link velodyne_top "$TMP/ground.urdf" \
    "$TMP/ground.launch.xml" "$TMP/sensors_calibration.yaml"; then
  pass "ground: URDF (liburdfdom), tf launch and sensors_calibration.yaml hold RESULT.json's z, pitch, roll"
else fail "ground: the ROS files disagree with RESULT.json"; fi
expect_status 2 "ground --write-urdf into a missing folder" "$AGVCAL" ground "$TMP/forklift3d.yaml" "$TMP/clouds.log" \
  --quiet --out "$TMP/none.json" --write-urdf "$TMP/no/such/dir/g.urdf"
stderr_has "--write-urdf"
if [ -e "$TMP/none.json" ]; then fail "a RESULT.json was written"; else pass "nothing written"; fi

# A KITTI frame (a real HDL-64E scan, ../shared/data): hashed, no recording date.
kitti=$SRC/../shared/data/kitti-velodyne-frames/raw_frame/000000.bin
if [ -r "$kitti" ]; then
  expect_status 0 "ground on a KITTI frame, writing the Autoware file" "$AGVCAL" ground config/robots/kitti_hdl64e.yaml \
    "$kitti" --quiet --out "$TMP/kitti.json" --write-urdf "$TMP/kitti.urdf" --write-tf "$TMP/kitti.launch.xml" \
    --write-autoware "$TMP/kitti_sensors.yaml" --lidar-frame velodyne_top_base_link
  origin "$TMP/kitti.urdf" velodyne_top_base_link_joint
  python3 - "$TMP/kitti.json" config/robots/kitti_hdl64e.yaml >"$TMP/kitti.expected.json" <<'PY'
import json, sys, yaml
r = json.load(open(sys.argv[1]))["lidar3d"]
m = yaml.safe_load(open(sys.argv[2]))["lidar3d"]
print(json.dumps({**{k: m.get(k, 0.0) for k in ("x", "y", "yaw")}, **{k: r[k]["value"] for k in ("z", "pitch", "roll")}}))
PY
  if python3 $check mount "$TMP/kitti.expected.json" "$kitti" base_link velodyne_top_base_link "$TMP/kitti.urdf" \
      "$TMP/kitti.launch.xml" "$TMP/kitti_sensors.yaml"; then
    pass "KITTI frame: the three files hold RESULT.json's z, pitch, roll"
  else fail "KITTI frame: the ROS files disagree with RESULT.json"; fi
  grep -q "no recording date" "$TMP/kitti_sensors.yaml" && pass "a cloud file has no recording date" \
    || fail "the KITTI file's provenance: $(head -3 "$TMP/kitti_sensors.yaml")"
else
  echo "SKIP KITTI frame: no $kitti"
fi

# recal: the forklift's work route; the files hold the calibration accepted at the end.
robot=config/robots/forklift_nav.yaml
"$AGVCAL" simulate config/sims/forklift_route.yaml "$TMP/route.log" --trajectory route >/dev/null 2>&1
expect_status 0 "recal, writing URDF and tf" "$AGVCAL" recal "$robot" "$TMP/route.log" --config config/recal.yaml \
  --out-robot "$TMP/recal.yaml" --write-urdf "$TMP/recal.urdf" --write-tf "$TMP/recal.launch.xml"
origin "$TMP/recal.urdf" laser_joint
python3 - "$TMP/recal.yaml" >"$TMP/recal.expected.json" <<'PY'
import json, sys, yaml
m = yaml.safe_load(open(sys.argv[1]))["lidar2d"]
print(json.dumps({"x": m["x"], "y": m["y"], "yaw": m["yaw"], "z": 0.0, "roll": 0.0, "pitch": 0.0}))
PY
if python3 $check mount "$TMP/recal.expected.json" "$TMP/route.log" base_link laser "$TMP/recal.urdf" \
    "$TMP/recal.launch.xml"; then
  pass "recal: URDF and tf hold the accepted calibration's lidar mount"
else fail "recal: the ROS files disagree with the accepted robot file"; fi
grep -q "the calibration in use at the end of the recording: recalibration decision" "$TMP/recal.urdf" &&
  pass "recal: the URDF names the decision" || fail "recal: the URDF does not name the decision"
expect_status 2 "recal --write-urdf from the pose source" "$AGVCAL" recal "$robot" "$TMP/route.log" \
  --config config/recal.yaml --source pose --write-urdf "$TMP/pose.urdf"
stderr_has "--write-urdf: needs the 2D lidar's mount"
if [ -e "$TMP/pose.urdf" ]; then fail "a URDF was written"; else pass "no URDF written"; fi

# solve, a tricycle: tricycle_controller and bicycle_steering_controller.
expect_status 0 "solve the forklift, writing controller, URDF and tf" "$AGVCAL" solve config/robots/forklift.yaml \
  logs/forklift_demo.log --quiet --out "$TMP/solve.json" --write-controller "$TMP/controllers.yaml" \
  --write-urdf "$TMP/solve.urdf" --write-tf "$TMP/solve.launch.xml"
origin "$TMP/solve.urdf" laser_joint
if python3 $check "$TMP/solve.json" "$TMP/controllers.yaml" logs/forklift_demo.log "$TMP/solve.urdf" \
    "$TMP/solve.launch.xml" laser; then
  pass "solve: tricycle and bicycle steering controllers, URDF and tf hold RESULT.json's values"
else fail "solve: the ROS files disagree with RESULT.json"; fi
finish
