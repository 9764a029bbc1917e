#!/usr/bin/env bash
# Regenerates the sample recordings in logs/ from config/sims (deterministic).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
for robot in diff_robot forklift dual_steer_agv; do
  build/agvcal simulate "config/sims/$robot.yaml" "logs/${robot%_agv}_demo.log" --trajectory demo --quiet
done
ls -l logs/
