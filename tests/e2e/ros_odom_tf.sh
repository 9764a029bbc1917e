#!/usr/bin/env bash
# A differential drive's own odometry (nav_msgs/Odometry, robot file ros.odom: {as: wheels})
# imported as its wheel states, and the bag's tf_static as the nominal lidar mount (import
# --write-robot; docs/ros.md): a ROS 1 bag written by Debian's python3-rosbag from the poses and
# scans of logs/diff_robot_demo.log, with a static transform base_link -> laser; the import's
# WHEELS agree with the poses inverted on their own (tests/ros/odom_wheels_check.py), the robot
# file written holds the transform, and the recording calibrates with it. Robot files and
# requests that cannot mean it exit 2.
source "$(dirname "$0")/lib.bash" "$@"
if ! /usr/bin/python3 -c 'import rosbag, nav_msgs.msg' 2>/dev/null; then
  echo "SKIP: no python3-rosbag / python3-nav-msgs"; exit 77
fi
py=$BUILD/lcmtypes-py
[ -d "$py/agvcal" ] || { echo "FAIL: no $py (the build's Python message types)"; exit 1; }

# The demo's true poses as the drive's odometry (/odom) and its scans.
python3 tests/ros/log_to_json.py "$py" logs/diff_robot_demo.log | grep '"channel": "SCAN"' >"$TMP/bag.jsonl"
messages() {  # messages LOG CHANNEL: its messages as JSON lines, decoded with the Python types
  python3 - "$py" "$1" "$2" <<'PY'
import json, sys
sys.path[:0] = [sys.argv[1], "tests/ros"]
from lcm_log import events
from agvcal import pose2d_t, wheel_state_t
types = {"GROUND_TRUTH": pose2d_t, "WHEELS": wheel_state_t}
for channel, data in events(sys.argv[2]):
    if channel == sys.argv[3]:
        m = types[channel].decode(data)
        print(json.dumps({"channel": "POSE" if channel == "GROUND_TRUTH" else channel,
                          **{f: list(getattr(m, f)) if isinstance(getattr(m, f), (list, tuple))
                             else getattr(m, f) for f in m.__slots__}}))
PY
}
messages logs/diff_robot_demo.log GROUND_TRUTH >"$TMP/poses.jsonl"
cat "$TMP/poses.jsonl" >>"$TMP/bag.jsonl"
echo '{"scan_frame": "laser", "lidar2d": {"x": 0.21, "y": 0.05, "yaw": 0.03}}' >"$TMP/mapping.json"
/usr/bin/python3 tests/ros/write_rosbag1.py "$TMP/bag.jsonl" "$TMP/mapping.json" "$TMP/odom.bag" ||
  { echo "FAIL: python3-rosbag could not write the bag"; exit 1; }

robot=$TMP/diff_odom.yaml
sed '/^ros:/,$d' config/robots/ros/diff_robot.yaml >"$robot"
cat >>"$robot" <<'YAML'
ros:
  odom: {topic: /odom, as: wheels}   # the drive's own odometry -> WHEELS
  scan: /scan
YAML
expect_status 0 "import the bag, odom as wheels, the mount from tf_static" "$AGVCAL" import rosbag "$TMP/odom.bag" \
  "$TMP/odom.log" --robot "$robot" --write-robot "$TMP/tf_robot.yaml"
stderr_has "wheel states from /odom's poses"
if python3 - "$TMP/tf_robot.yaml" <<'PY'
import sys, yaml
m = yaml.safe_load(open(sys.argv[1]))["lidar2d"]
want = {"x": 0.21, "y": 0.05, "yaw": 0.03}
bad = {k: m[k] for k in want if abs(m[k] - want[k]) > 1e-9}
sys.exit(f"lidar2d {bad}, tf_static {want}" if bad else 0)
PY
then pass "--write-robot: lidar2d x, y, yaw are tf_static's base_link -> laser"
else fail "--write-robot: lidar2d differs from tf_static"; fi
messages "$TMP/odom.log" WHEELS >"$TMP/wheels.jsonl"
if python3 tests/ros/odom_wheels_check.py "$TMP/poses.jsonl" "$TMP/wheels.jsonl" 0.075 0.075 0.45; then
  pass "WHEELS are the poses inverted with the nominal radii and track (1e-9 rad)"
else fail "WHEELS disagree with the poses"; fi
expect_status 0 "solve the import with the robot file written" "$AGVCAL" solve "$TMP/tf_robot.yaml" "$TMP/odom.log" \
  --quiet --out "$TMP/odom.json"

# Robot files that cannot mean it.
sed 's/^  scan: \/scan/  scan: \/scan\n  joint_states: {wheels: {left: l, right: r}}/' "$robot" >"$TMP/both.yaml"
expect_status 2 "odom as wheels and joint_states" "$AGVCAL" import rosbag "$TMP/odom.bag" "$TMP/x.log" --robot "$TMP/both.yaml"
stderr_has "odom as wheels and joint_states both give WHEELS"
sed 's/as: wheels/as: wheel/' "$robot" >"$TMP/typo.yaml"
expect_status 2 "odom as: wheel" "$AGVCAL" import rosbag "$TMP/odom.bag" "$TMP/x.log" --robot "$TMP/typo.yaml"
stderr_has "expected pose (an external pose source -> POSE) or wheels"
[ -e "$TMP/x.log" ] && fail "a recording was written" || pass "no recording written"
expect_status 2 "--write-robot for a CARMEN log" "$AGVCAL" import carmen "$TMP/odom.bag" "$TMP/x.log" \
  --robot "$robot" --write-robot "$TMP/x.yaml"
stderr_has "--write-robot: only for rosbag2 and rosbag"
[ -e "$TMP/x.yaml" ] && fail "a robot file was written" || pass "no robot file written"
finish
