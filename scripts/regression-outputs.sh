#!/usr/bin/env bash
# Writes every result file the offline commands produce for a fixed set of inputs (the sample
# logs, simulated recordings of each sim config, the real datasets of ../shared/data when
# present) into OUTDIR, so that two builds can be compared byte for byte:
#   scripts/regression-outputs.sh OUTDIR            # with build/ (or $AGVCAL_BIN)
#   diff -r BEFORE AFTER                            # a refactoring must print nothing
# Exit statuses are recorded too (OUTDIR/status.txt); stdout and stderr of each run are kept.
# Options: --quick (the sample logs only, about a minute).
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
out=${1:?usage: scripts/regression-outputs.sh OUTDIR [--quick]}
quick=${2:-}
agvcal=${AGVCAL_BIN:-$here/build}/agvcal
[ -x "$agvcal" ] || { echo "no $agvcal (build first, or set AGVCAL_BIN)" >&2; exit 2; }
mkdir -p "$out"
: > "$out/status.txt"
# One run at a time on this machine (the work folder below is fixed).
exec 9> /tmp/agvcal-regression.lock
flock 9

run() {  # run NAME COMMAND...: stdout, stderr and exit status under OUTDIR/NAME.*
  local name=$1; shift
  "$@" > "$out/$name.stdout" 2> "$out/$name.stderr"
  echo "$name $?" >> "$out/status.txt"
}

# The sample logs: solve (plain, held-out half, time offset, written robot file) and diagnose.
for pair in forklift:forklift diff_robot:diff_robot dual_steer:dual_steer_agv; do
  log=logs/${pair%%:*}_demo.log robot=config/robots/${pair#*:}.yaml name=${pair%%:*}
  run "$name.info" "$agvcal" info "$log"
  run "$name.solve" "$agvcal" solve "$robot" "$log" --quiet --out "$out/$name.result.json" \
    --write-robot "$out/$name.cal.yaml"
  run "$name.solve_heldout" "$agvcal" solve "$robot" "$log" --fit-fraction 0.5 --out "$out/$name.heldout.json"
  run "$name.solve_offset" "$agvcal" solve "$robot" "$log" --quiet --time-offset --out "$out/$name.offset.json"
  run "$name.diagnose" "$agvcal" diagnose "$robot" "$log" --quiet --out "$out/$name.report.json" \
    --report "$out/$name.report" --write-sim "$out/$name.reproduce.yaml"
done
[ "$quick" = "--quick" ] && exit 0

# A fixed work folder: paths appear in the outputs, so both runs must use the same ones.
tmp=/tmp/agvcal-regression-work
rm -rf "$tmp"; mkdir -p "$tmp"
# Simulated recordings (their bytes are compared too) and the commands made for them.
run sim.imu "$agvcal" simulate config/sims/imu_robot.yaml "$out/imu.log" --trajectory demo --quiet
run imu.solve "$agvcal" solve config/robots/imu_robot.yaml "$out/imu.log" --source imu --quiet --out "$out/imu.result.json"
run imu.fuse "$agvcal" fuse config/robots/imu_robot.yaml "$out/imu.log" --out "$out/imu.poses.csv"
run sim.route "$agvcal" simulate config/sims/forklift_route.yaml "$tmp/route.log" --trajectory route --quiet
sha256sum "$tmp/route.log" | cut -c1-64 > "$out/route.log.sha256"
run route.recal "$agvcal" recal config/robots/forklift.yaml "$tmp/route.log" --config config/recal.yaml \
  --out-robot "$out/route.recal.yaml" --decisions "$out/route.decisions.jsonl"
cat > "$tmp/sim3d.yaml" <<EOF
robot: $here/config/robots/forklift.yaml
truth:
  lidar3d: {z: 1.912, pitch: 0.035, roll: -0.012}
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 0}
  lidar3d: {rate: 10, rings: 16, points_per_ring: 360, body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]}}
EOF
if run sim.clouds "$agvcal" simulate "$tmp/sim3d.yaml" "$tmp/clouds.log" --trajectory demo --quiet; then
  run clouds.ground "$agvcal" ground config/robots/forklift.yaml "$tmp/clouds.log" --out "$out/clouds.ground.json"
fi
for effect in "time_offset: {offset_s: 0.005}" "longitudinal_slip: {slip_per_accel: 0.01}"; do
  key=${effect%%:*}
  { sed "s|^robot: ../|robot: $here/config/|" config/sims/diff_robot.yaml; echo "effects: {$effect}"; } > "$tmp/$key.yaml"
  run "sim.$key" "$agvcal" simulate "$tmp/$key.yaml" "$tmp/$key.log" --trajectory demo --quiet
  run "$key.diagnose" "$agvcal" diagnose config/robots/diff_robot.yaml "$tmp/$key.log" --quiet \
    --out "$out/$key.report.json"
done

# The real datasets (imported, then solved with the held-out half and diagnosed).
data=${AGVCAL_DATA_DIR:-$here/../shared/data}
if [ -d "$data" ]; then
  source scripts/dataset-robots.bash
  AGVCAL_BIN=$(dirname "$agvcal") scripts/import-datasets.sh "$tmp/real" "$data" 2>&1 | grep -v '^-rw' > "$out/import.txt"
  for log in "$tmp"/real/*.log; do
    name=$(basename "$log" .log)
    robot=$(dataset_robot "$name") || continue
    sha256sum "$log" | cut -c1-64 > "$out/real.$name.log.sha256"
    run "real.$name.solve" "$agvcal" solve "config/robots/datasets/$robot" "$log" --fit-fraction 0.5 --quiet \
      --out "$out/real.$name.result.json"
    run "real.$name.diagnose" "$agvcal" diagnose "config/robots/datasets/$robot" "$log" --quiet \
      --out "$out/real.$name.report.json"
  done
fi
