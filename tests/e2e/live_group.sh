#!/usr/bin/env bash
# The live process group (simulator, commander, lcm-logger as separate
# processes) in a private network namespace, for each drive type: the
# recording has every channel at its rate, and the true motion followed the
# commanded one.
source "$(dirname "$0")/lib.bash" "$@"
for robot in diff_robot forklift dual_steer_agv; do
  log=$TMP/$robot.log
  expect_status 0 "$robot: group runs the demo trajectory" \
    timeout 240 scripts/netns-run scripts/agvcal-group --sim config/sims/$robot.yaml \
      --trajectory demo --speed 4 --log "$log" --no-solver
  expect_status 0 "$robot: recording decodes" "$AGVCAL" info "$log"
  rates="WHEELS=100 SCAN=20 GROUND_TRUTH=100 DRIVE_CMD=20"
  [ "$robot" = dual_steer_agv ] || rates="$rates IMU=200"
  if "$CHECK" rates "$log" $rates && "$CHECK" tracking "$log" config/robots/$robot.yaml; then
    pass "$robot: channels, rates and tracking"
  else
    fail "$robot: channels, rates or tracking"
  fi
done
no_orphans
finish
