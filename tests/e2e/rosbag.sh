#!/usr/bin/env bash
# agvcal import rosbag2 / rosbag: real recordings of ../shared/data, written into bags by
# independent writers (@mcap/core + @foxglove/rosmsg2-serialization for MCAP with zstd, lz4
# and no compression; Python's sqlite3 for the .db3 bag; Debian's python3-rosbag for ROS 1,
# plain and bz2; tests/ros/), import back to the
# direct import's recording byte for byte (header stamps, not the bag's record times) and
# calibrate to the same RESULT.json. Bad bags: one line naming the file, the record and the
# problem, exit 2, no output.
source "$(dirname "$0")/lib.bash" "$@"
DATA=${AGVCAL_DATA_DIR:-$SRC/../shared/data}
WRITERS=$BUILD/ros-writers   # made by the ros_writers fixture (tests/ros/install.sh)
if [ ! -d "$WRITERS/node_modules/@mcap/core" ]; then
  echo "SKIP: no independent bag writers in $WRITERS (tests/ros/install.sh needs the npm registry)"
  exit 77
fi
# Node resolves an ES module's packages beside the script: a copy of it beside the packages.
ln -s "$WRITERS/node_modules" "$TMP/node_modules"
cp tests/ros/write_bags.mjs "$TMP/write_bags.mjs"
lcm-gen -p --ppath "$TMP/lcmpy" lcmtypes/*.lcm >/dev/null
mapping=$TMP/mapping.json

# bags RECORDING.log NAME: NAME.mcap (zstd), NAME-lz4.mcap, NAME-plain.mcap, NAME_db3/ (sqlite3),
# NAME.bag and NAME-bz2.bag (ROS 1)
bags() {
  python3 tests/ros/log_to_json.py "$TMP/lcmpy" "$1" >"$TMP/$2.jsonl"
  node "$TMP/write_bags.mjs" "$TMP/$2.jsonl" "$mapping" "$TMP/$2.mcap" zstd "$TMP/$2.cdr.jsonl" &&
    node "$TMP/write_bags.mjs" "$TMP/$2.jsonl" "$mapping" "$TMP/$2-lz4.mcap" lz4 &&
    node "$TMP/write_bags.mjs" "$TMP/$2.jsonl" "$mapping" "$TMP/$2-plain.mcap" none &&
    python3 tests/ros/write_db3.py "$TMP/$2.cdr.jsonl" "$TMP/$2_db3" &&
    /usr/bin/python3 tests/ros/write_rosbag1.py "$TMP/$2.jsonl" "$mapping" "$TMP/$2.bag" &&
    /usr/bin/python3 tests/ros/write_rosbag1.py "$TMP/$2.jsonl" "$mapping" "$TMP/$2-bz2.bag" bz2 ||
    fail "writing the bags of $2"
}
# robot_with_ros ROBOT.yaml OUT.yaml ROS_BLOCK
robot_with_ros() { { cat "$1"; printf '%s\n' "$3"; } >"$2"; }

# Damaged copies of the mines bags: exit 2, one line naming the file, the record and the problem.
bad() {  # bad WHAT FORMAT INPUT ROBOT EXPECTED...
  local what=$1 format=$2 input=$3 robot_file=$4; shift 4
  expect_status 2 "$what" "$AGVCAL" import "$format" "$input" "$TMP/out.log" --robot "$robot_file"
  for text in "$@"; do stderr_has "$text"; done
  if [ "$(wc -l <"$TMP/stderr")" -eq 1 ]; then pass "$what: one line"; else fail "$what: $(cat "$TMP/stderr")"; fi
  if [ -e "$TMP/out.log" ]; then fail "$what: an output file was left"; rm -f "$TMP/out.log"; fi
}
bad_bags() {
  head -c $(($(stat -c %s "$TMP/mines.mcap") / 2)) "$TMP/mines.mcap" >"$TMP/cut.mcap"
  bad "truncated MCAP" rosbag2 "$TMP/cut.mcap" "$robot" "cut.mcap: record" "truncated"
  python3 -c "import sys; b = bytearray(open(sys.argv[1], 'rb').read()); b[len(b) // 3] ^= 0x10
open(sys.argv[2], 'wb').write(b)" "$TMP/mines-plain.mcap" "$TMP/flip.mcap"
  bad "a flipped bit in a chunk" rosbag2 "$TMP/flip.mcap" "$robot" "flip.mcap: record" "chunk CRC mismatch"
  python3 -c "import sys; b = open(sys.argv[1], 'rb').read().replace(b'zstd', b'zstx')
open(sys.argv[2], 'wb').write(b)" "$TMP/mines.mcap" "$TMP/zstx.mcap"
  bad "unknown compression" rosbag2 "$TMP/zstx.mcap" "$robot" "zstx.mcap: record" "unknown chunk compression 'zstx'"
  cp -r "$TMP/mines_db3" "$TMP/xdr_db3"
  python3 -c "import sqlite3, sys; d = sqlite3.connect(sys.argv[1])
d.execute(\"UPDATE topics SET serialization_format = 'xdr'\"); d.commit()" "$TMP/xdr_db3/mines_db3_0.db3"
  bad "unknown message encoding" rosbag2 "$TMP/xdr_db3" "$robot" "mines_db3_0.db3: messages row id 2 (topic /joint_states" "unknown message encoding 'xdr'"
  head -c 20000 "$TMP/mines_db3/mines_db3_0.db3" >"$TMP/cut.db3"
  bad "truncated .db3" rosbag2 "$TMP/cut.db3" "$robot" "cut.db3: " "SQLite: "
  head -c 30000 "$TMP/mines.bag" >"$TMP/cut.bag"
  bad "truncated ROS 1 bag" rosbag "$TMP/cut.bag" "$robot" "cut.bag: " "not a readable ROS 1 bag"
  sed 's|  scan: /scan|  scan: /scan_front|' "$robot" >"$TMP/missing.yaml"
  bad "a topic not in the bag" rosbag2 "$TMP/mines.mcap" "$TMP/missing.yaml" "mines.mcap: topic /scan_front (robot file ros.scan)" "not in the bag; its topics: /joint_states"
  sed 's|  scan: /scan|  scan: /joint_states|' "$robot" >"$TMP/wrong.yaml"
  bad "a topic of another type" rosbag "$TMP/mines.bag" "$TMP/wrong.yaml" "is sensor_msgs/JointState, expected sensor_msgs/msg/LaserScan"
  sed '/^ros:/,$d' "$robot" >"$TMP/noros.yaml"
  bad "a robot file without ros:" rosbag2 "$TMP/mines.mcap" "$TMP/noros.yaml" "noros.yaml: ros: " "no ros: block"
}

mines=$DATA/mines-rover-coreslam/exp1.dat.gz
robot=$TMP/mines.yaml
robot_with_ros config/robots/datasets/mines_rover.yaml "$robot" "ros:
  joint_states: {topic: /joint_states, wheels: {left: left_wheel_joint, right: right_wheel_joint}}
  scan: /scan"
echo '{"wheel_joints": {"left": "left_wheel_joint", "right": "right_wheel_joint"},
       "scan_frame": "laser", "lidar2d": {"x": 0.145, "y": 0, "yaw": 0}}' >"$mapping"
if [ -f "$mines" ]; then
  "$AGVCAL" import mines "$mines" "$TMP/direct.log" --robot "$robot" --quiet
  bags "$TMP/direct.log" mines
  for bag in mines.mcap mines-lz4.mcap mines-plain.mcap mines_db3 mines_db3/mines_db3_0.db3 mines.bag mines-bz2.bag; do
    format=rosbag2; [[ $bag == *.bag ]] && format=rosbag
    expect_status 0 "import $format $bag" "$AGVCAL" import $format "$TMP/$bag" "$TMP/bag.log" --robot "$robot"
    if cmp -s "$TMP/direct.log" "$TMP/bag.log"; then pass "$bag: the direct import's recording, byte for byte"
    else fail "$bag: the recording differs from the direct import's"; fi
  done
  stderr_has "tf_static base_link -> laser: x 0.1450 y 0.0000 z 0.3000 m"
  expect_status 0 "solve the direct import" "$AGVCAL" solve "$robot" "$TMP/direct.log" --quiet --out "$TMP/direct.json"
  expect_status 0 "solve the bag's import, writing the ROS files" "$AGVCAL" solve "$robot" "$TMP/bag.log" \
    --quiet --out "$TMP/bag.json" --write-urdf "$TMP/lidar.urdf" --write-tf "$TMP/tf.launch.xml" \
    --write-controller "$TMP/controller.yaml" --lidar-frame hokuyo_link
  "$BUILD/tests/urdf_joint_origin" "$TMP/lidar.urdf" hokuyo_link_joint >"$TMP/lidar.urdf.origin" ||
    fail "liburdfdom does not read the URDF: $(cat "$TMP/lidar.urdf")"
  if /usr/bin/python3 tests/ros/check_ros_results.py "$TMP/bag.json" "$TMP/controller.yaml" "$TMP/bag.log" \
      "$TMP/lidar.urdf" "$TMP/tf.launch.xml" hokuyo_link; then
    pass "URDF (liburdfdom), static tf launch and diff_drive_controller parameters hold RESULT.json's values"
  else fail "the ROS files disagree with RESULT.json"; fi
  # The recording's own name is in the result; every number must agree.
  if diff <(python3 tests/tools/without_provenance.py "$TMP/direct.json" | grep -v '"log"') \
          <(python3 tests/tools/without_provenance.py "$TMP/bag.json" | grep -v '"log"') >/dev/null; then
    pass "same calibration from the bag as from the direct import"
  else fail "calibrations differ: $(diff "$TMP/direct.json" "$TMP/bag.json" | head -20)"; fi
  # Record times instead of header stamps: each topic's latency shifts its stream.
  sed 's/^ros:$/ros:\n  stamps: record/' "$robot" >"$TMP/record.yaml"
  expect_status 0 "import with record times" "$AGVCAL" import rosbag2 "$TMP/mines.mcap" "$TMP/record.log" --robot "$TMP/record.yaml"
  if cmp -s "$TMP/direct.log" "$TMP/record.log"; then fail "record times gave the header stamps"
  else pass "ros.stamps: record stamps with the bag's record times"; fi
  bad_bags
else
  echo "SKIP real-data checks: no $mines"
fi

# A tricycle with a steering joint and an external pose (nav_msgs/Odometry).
run=$DATA/optiodom-sousa/tricyc/circular/140120211415/140120211415_run-01.csv.gz
robot3=$TMP/tricycle.yaml
robot_with_ros config/robots/datasets/optiodom_tricycle.yaml "$robot3" "ros:
  joint_states: {wheels: {drive: traction_joint}, steering: {drive: steering_joint}}
  odom: /odom"
echo '{"wheel_joints": {"drive": "traction_joint"}, "steer_joints": {"drive": "steering_joint"},
       "scan_frame": "laser", "lidar2d": null}' >"$mapping"
if [ -f "$run" ]; then
  "$AGVCAL" import optiodom "$run" "$TMP/tri.log" --robot "$robot3" --quiet
  bags "$TMP/tri.log" tri
  expect_status 0 "solve the direct import" "$AGVCAL" solve "$robot3" "$TMP/tri.log" --source pose --quiet --out "$TMP/tri.json"
  for bag in tri_db3 tri.mcap tri.bag; do
    format=rosbag2; [[ $bag == *.bag ]] && format=rosbag
    expect_status 0 "import $format $bag (tricycle, Odometry)" "$AGVCAL" import $format "$TMP/$bag" "$TMP/tri-bag.log" --robot "$robot3"
    stderr_has "WHEELS: "; stderr_has "POSE: "
    expect_status 0 "solve the import of $bag" "$AGVCAL" solve "$robot3" "$TMP/tri-bag.log" --source pose --quiet \
      --out "$TMP/tri-bag.json" --write-controller "$TMP/tricycle_controller.yaml"
    if /usr/bin/python3 tests/ros/check_ros_results.py "$TMP/tri-bag.json" "$TMP/tricycle_controller.yaml" "$TMP/tri-bag.log"; then
      pass "$bag: tricycle_controller parameters hold RESULT.json's values"
    else fail "$bag: tricycle_controller parameters disagree with RESULT.json"; fi
    # The heading goes through a quaternion: equal to the last bits, not bit for bit.
    if python3 tests/ros/same_numbers.py "$TMP/tri.json" "$TMP/tri-bag.json" 1e-9; then
      pass "$bag: same calibration (1e-9 relative) from the steering joint and the odometry"
    else fail "$bag: tricycle calibrations differ"; fi
  done
  expect_status 2 "--write-urdf without a lidar" "$AGVCAL" solve "$robot3" "$TMP/tri.log" --source pose --quiet \
    --write-urdf "$TMP/none.urdf"
  stderr_has "--write-urdf: needs the 2D lidar's mount"
  if [ -e "$TMP/none.urdf" ]; then fail "a URDF was written"; else pass "no URDF written"; fi
else
  echo "SKIP tricycle checks: no $run"
fi
# IMU and drive commands: the simulated sample has them (and no real dataset does).
robot=config/robots/ros/diff_robot.yaml
echo '{"wheel_joints": {"left_wheel": "left_wheel_joint", "right_wheel": "right_wheel_joint"},
       "scan_frame": "laser", "lidar2d": {"x": 0.2, "y": 0, "yaw": 0}, "imu_topic": "/imu/data"}' >"$mapping"
bags logs/diff_robot_demo.log demo
for bag in demo-lz4.mcap demo.bag; do
  format=rosbag2; [[ $bag == *.bag ]] && format=rosbag
  expect_status 0 "import $format $bag (IMU, TwistStamped)" "$AGVCAL" import $format "$TMP/$bag" "$TMP/demo.log" --robot "$robot"
  stderr_has "IMU: 5151 messages"; stderr_has "DRIVE_CMD: 495 messages"
  stderr_has "(the scan's frame; robot file lidar2d: x 0.2000 y 0.0000 yaw 0.00000)"
  python3 tests/ros/log_to_json.py "$TMP/lcmpy" "$TMP/demo.log" >"$TMP/demo-bag.jsonl"
  if python3 tests/ros/same_messages.py "$TMP/demo.jsonl" "$TMP/demo-bag.jsonl" WHEELS SCAN IMU DRIVE_CMD; then
    pass "$bag: WHEELS, SCAN, IMU and DRIVE_CMD (body twists) as the sample has them"
  else fail "$bag: messages differ from the sample's"; fi
done
finish
