#!/usr/bin/env bash
# Writes the human report (--report DIR, docs/reports.md) of each command into OUT:
#   OUT/diagnose  the simulated forklift with a 0.1 s drive lag (config/sims/forklift.yaml + effect)
#   OUT/solve     the forklift sample logs/forklift_demo.log, the last 30 % held out
#   OUT/ground    the simulated forklift's 3D lidar on the demo route (config/sims/forklift_lidar3d.yaml)
#   OUT/recal     the forklift's simulated work route (config/sims/forklift_route.yaml)
#   OUT/fleet     agvcal-fleet's pages of a small simulated fleet (agvcal-fleet synth: a forklift
#                 with a step and a truncated recording, a drifting differential drive; 5 recordings each over 28 days)
# The recordings are made in OUT/work. Used by the report tests (tests/reports/reports.sh) and
# scripts/report-screenshots.sh.
# Usage: scripts/make-reports.sh BUILD OUT
set -eu
BUILD=$(cd "${1:?build dir}" && pwd)
mkdir -p "${2:?output dir}/work"
OUT=$(cd "$2" && pwd)
SRC=$(cd "$(dirname "$0")/.." && pwd)
W=$OUT/work
AGVCAL=$BUILD/agvcal
cd "$SRC"
say() { echo "make-reports: $*" >&2; }

say "diagnose: simulated forklift with drive_lag tau_s 0.1"
sed "s|^robot: ../robots/|robot: $SRC/config/robots/|" config/sims/forklift.yaml > "$W/lag.yaml"
printf 'effects:\n  drive_lag: {tau_s: 0.1}\n' >> "$W/lag.yaml"
"$AGVCAL" simulate "$W/lag.yaml" "$W/lag.log" --trajectory demo --quiet
"$AGVCAL" diagnose config/robots/forklift.yaml "$W/lag.log" --quiet --report "$OUT/diagnose" > "$W/diagnose.txt"

say "solve: logs/forklift_demo.log, 30 % held out"
"$AGVCAL" solve config/robots/forklift.yaml logs/forklift_demo.log --quiet --fit-fraction 0.7 \
  --report "$OUT/solve" > "$W/solve.txt"

say "ground: simulated 3D lidar"
"$AGVCAL" simulate config/sims/forklift_lidar3d.yaml "$W/clouds.log" --trajectory demo --quiet
"$AGVCAL" ground config/robots/forklift.yaml "$W/clouds.log" --quiet --report "$OUT/ground"

say "recal: the forklift's work route"
"$AGVCAL" simulate config/sims/forklift_route.yaml "$W/route.log" --trajectory route --quiet
"$AGVCAL" recal config/robots/forklift_nav.yaml "$W/route.log" --config config/recal.yaml \
  --report "$OUT/recal" > "$W/recal.txt"
say "fleet: two simulated robots, 5 recordings each and a truncated one"
AGVCAL_BIN=$BUILD scripts/agvcal-fleet synth "$W/fleet" --plan step@forklift,drift@diff --recordings 5 --days 28 \
  --broken 1 --seed 7 --jobs 2 --quiet
AGVCAL_BIN=$BUILD scripts/agvcal-fleet run "$W/fleet/fleet.yaml" --db "$W/fleet.sqlite" --workers 2 --quiet
AGVCAL_BIN=$BUILD scripts/agvcal-fleet report --db "$W/fleet.sqlite" --out "$OUT/fleet"
say "done: $OUT/{diagnose,solve,ground,recal,fleet}/index.html"
