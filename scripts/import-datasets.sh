#!/usr/bin/env bash
# Imports every dataset of ../shared/data (docs/datasets.md) into recordings in OUTDIR:
#   scripts/import-datasets.sh OUTDIR [DATA_DIR]
# DATA_DIR defaults to $AGVCAL_DATA_DIR or ../shared/data next to this checkout; the
# agvcal binary to $AGVCAL_BIN/agvcal or build/agvcal. The outputs are not committed.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
out=${1:?usage: scripts/import-datasets.sh OUTDIR [DATA_DIR]}
data=${2:-${AGVCAL_DATA_DIR:-$here/../shared/data}}
agvcal=${AGVCAL_BIN:-$here/build}/agvcal
robots=$here/config/robots/datasets
[ -x "$agvcal" ] || { echo "no $agvcal (build first, or set AGVCAL_BIN)" >&2; exit 2; }
[ -d "$data" ] || { echo "no data directory $data" >&2; exit 2; }
mkdir -p "$out"

run() {  # run FORMAT INPUT NAME ROBOT
  echo "== $3"
  "$agvcal" import "$1" "$2" "$out/$3.log" --robot "$robots/$4"
}
run carmen "$data/mit-csail-carmen/mit-csail.clf.gz" mit_csail mit_csail.yaml
for e in exp1 exp2; do
  run mines "$data/mines-rover-coreslam/$e.dat.gz" "mines_$e" mines_rover.yaml
done
run lego "$data/lego-robot-brenner/robot4_motors.txt" lego_robot4 lego_robot.yaml
for f in "$data"/optiodom-sousa/tricyc/*/*/*_run-[0-9][0-9].csv.gz; do
  kind=$(basename "$(dirname "$(dirname "$f")")")
  run optiodom "$f" "optiodom_tricycle_${kind}_$(basename "$f" .csv.gz)" optiodom_tricycle.yaml
done
for f in "$data"/optiodom-sousa/diff/*/*/*_run-[0-9][0-9].csv.gz; do
  kind=$(basename "$(dirname "$(dirname "$f")")")
  run optiodom "$f" "optiodom_diff_${kind}_$(basename "$f" .csv.gz)" optiodom_diff.yaml
done
echo "== recordings in $out"
ls -l "$out"
