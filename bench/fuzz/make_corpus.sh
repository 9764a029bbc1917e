#!/usr/bin/env bash
# Regenerates the committed seed corpus bench/fuzz/corpus/<target>/ (a few hundred kB):
# the binary seeds by fuzz_seeds (from the sample logs, bench/fuzz/fuzz_seeds.cc), the text
# ones cut from the bundled configs and the real datasets (AGVCAL_DATA_DIR, default ../shared/data).
#   bench/fuzz/make_corpus.sh [FUZZ_BUILD_DIR]     (default build-fuzz; bench/fuzz/run.sh makes it)
set -eu  # no pipefail: zcat | head ends zcat early
case "${1:-}" in -h|--help) sed -n '2,5p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
here=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$here/build-fuzz}
data=${AGVCAL_DATA_DIR:-$here/../shared/data}
corpus=$here/bench/fuzz/corpus
rm -rf "$corpus"
for t in recording messages robot_file sim_config pcd kitti carmen mines lego optiodom pose_csv candump \
         sick_cola bridge_config mcap; do mkdir -p "$corpus/$t"; done
"$build/bench/fuzz/fuzz_seeds" "$corpus"
cp "$here"/config/robots/*.yaml "$here"/config/robots/datasets/*.yaml "$corpus/robot_file/"
cp "$here"/config/sims/*.yaml "$corpus/sim_config/"
for f in "$here"/config/bridges/*.yaml; do
  case $f in *can*) k='\x01' ;; *) k='\x00' ;; esac
  { printf "$k"; cat "$f"; } > "$corpus/bridge_config/$(basename "$f")"
done
# Clouds: KITTI records (16 bytes each) and PCDs in the three encodings, a VIEWPOINT and an extra field.
head -c 1600 "$data/kitti-velodyne-frames/raw_frame/000000.bin" > "$corpus/kitti/raw.bin"
python3 - "$corpus/pcd" <<'PY'
import struct, sys
d = sys.argv[1]
pts = [(1.0, 2.0, 0.5), (-1.5, 0.25, -0.1), (3.0, -2.0, 1.0), (float('nan'), 0.0, 0.0)]
def header(fields, size, type_, count, data, vp="0 0 0 1 0 0 0"):
    return ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS %s\nSIZE %s\nTYPE %s\n"
            "COUNT %s\nWIDTH %d\nHEIGHT 1\nVIEWPOINT %s\nPOINTS %d\nDATA %s\n"
            % (fields, size, type_, count, len(pts), vp, len(pts), data)).encode()
open(d + "/ascii.pcd", "wb").write(header("x y z", "4 4 4", "F F F", "1 1 1", "ascii", "1 2 0 0.7071 0 0 0.7071")
                                  + b"".join(b"%g %g %g\n" % p for p in pts))
open(d + "/binary.pcd", "wb").write(header("x y z intensity", "4 4 4 4", "F F F F", "1 1 1 1", "binary")
                                   + b"".join(struct.pack("<4f", *p, 7.0) for p in pts))
open(d + "/double.pcd", "wb").write(header("x y z", "8 8 8", "F F F", "1 1 1", "binary")
                                   + b"".join(struct.pack("<3d", *p) for p in pts))
# binary_compressed: the fields one after another (x x x x y y y y z z z z), LZF literal runs only.
raw = b"".join(struct.pack("<%df" % len(pts), *[p[i] for p in pts]) for i in range(3))
lzf = b"".join(bytes([len(raw[i:i + 32]) - 1]) + raw[i:i + 32] for i in range(0, len(raw), 32))
open(d + "/compressed.pcd", "wb").write(header("x y z", "4 4 4", "F F F", "1 1 1", "binary_compressed")
                                       + struct.pack("<II", len(lzf), len(raw)) + lzf)
PY
# Dataset importers: the first lines of each real file.
zcat "$data/mit-csail-carmen/mit-csail.clf.gz" | head -25 > "$corpus/carmen/mit-csail.clf"
zcat "$data/mit-csail-carmen/mit-csail.clf.gz" | grep -m 6 -E '^(ODOM|FLASER)' > "$corpus/carmen/odom_flaser.clf"
zcat "$data/mines-rover-coreslam/exp1.dat.gz" | head -4 > "$corpus/mines/exp1.dat"
{ head -30 "$data/lego-robot-brenner/robot4_motors.txt"; printf '\n====\n'
  zcat "$data/lego-robot-brenner/robot4_scan.txt.gz" | head -3; } > "$corpus/lego/robot4"
for kind in diff tricyc; do
  meta=$(find "$data/optiodom-sousa/$kind" -name '*_metadata.csv*' | sort | head -1)
  run=$(find "$data/optiodom-sousa/$kind" -name '*_run-*.csv*' | sort | head -1)
  { zcat -f "$meta"; printf '\n====\n'; zcat -f "$run" | head -40; } > "$corpus/optiodom/$kind"
done
printf 'time, x, y, theta\n1000000, 0.0, 0.0, 0.0\n1050000, 0.1, 0.0, 0.01\n' > "$corpus/pose_csv/micros.csv"
printf '# seconds, 3 variances\n1.0,0,0,0,0.01,0.01,0.001\n1.05,0.1,0,0.01,0.01,0.01,0.001\n' > "$corpus/pose_csv/seconds.csv"
gzip -c "$corpus/pose_csv/micros.csv" > "$corpus/pose_csv/micros.csv.gz"
# MCAP: the sample log's first messages in bags of @mcap/core (tests/ros: zstd, lz4, none),
# when its writers are installed (tests/ros/install.sh, AGVCAL_ROS_WRITERS).
writers=${AGVCAL_ROS_WRITERS:-$here/build/ros-writers}
if [ -d "$writers/node_modules/@mcap/core" ]; then
  tmp=$(mktemp -d)
  lcm-gen -p --ppath "$tmp" "$here"/lcmtypes/*.lcm >/dev/null
  ln -s "$writers/node_modules" "$tmp/node_modules"   # an ES module finds its packages beside it
  cp "$here/tests/ros/write_bags.mjs" "$tmp/"
  python3 "$here/tests/ros/log_to_json.py" "$tmp" "$here/logs/diff_robot_demo.log" | head -60 > "$tmp/m.jsonl"
  echo '{"wheel_joints": {"left_wheel": "left_wheel_joint", "right_wheel": "right_wheel_joint"},
         "scan_frame": "laser", "lidar2d": {"x": 0.2, "y": 0, "yaw": 0}, "imu_topic": "/imu/data"}' \
    > "$tmp/map.json"
  for c in zstd lz4 none; do
    node "$tmp/write_bags.mjs" "$tmp/m.jsonl" "$tmp/map.json" \
      "$corpus/mcap/diff_robot_$c.mcap" "$c"
  done
  rm -rf "$tmp"
else
  echo "no MCAP seeds: no $writers/node_modules (tests/ros/install.sh)" >&2
fi
du -sh "$corpus"
