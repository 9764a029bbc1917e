#!/usr/bin/env bash
# `agvcal diagnose --jobs`: the candidates' fits on two threads give the same REPORT.json and
# summary.txt, byte for byte below their provenance, as on one, on the differential and tricycle sample logs and on a simulated recording with
# effects (a time offset and longitudinal slip, which the selection has to tell apart).
source "$(dirname "$0")/lib.bash" "$@"

same_on_1_and_2() {  # ROBOT LOG NAME
  local robot=$1 log=$2 name=$3
  for jobs in 1 2; do
    expect_status 0 "$name: diagnose --jobs $jobs" \
      "$AGVCAL" diagnose "$robot" "$log" --quiet --jobs "$jobs" --out "$TMP/$name-$jobs.json" --report "$TMP/$name-$jobs"
  done
  # The provenance (the command line, with its --jobs, and the date) is the run's own.
  if python3 - "$TMP/$name-1.json" "$TMP/$name-2.json" <<'PY'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
assert "provenance" in a and "provenance" in b
for r in (a, b):
    del r["provenance"]
assert a == b
PY
  then pass "$name: REPORT.json the same"; else fail "$name: REPORT.json differs"; fi
  if cmp -s <(sed '1,/^$/d' "$TMP/$name-1/summary.txt") <(sed '1,/^$/d' "$TMP/$name-2/summary.txt"); then
    pass "$name: summary.txt the same"
  else
    fail "$name: summary.txt differs"
  fi
}

same_on_1_and_2 config/robots/diff_robot.yaml logs/diff_robot_demo.log diff_robot
same_on_1_and_2 config/robots/forklift.yaml logs/forklift_demo.log forklift
# (logs/dual_steer_demo.log is too short for the diagnosis: exit 3, 37 usable intervals.)

# A recording with effects: the forklift's sim with a time offset and floor slip added.
sed -e '/^effects:/,$d' -e "s|^robot: ../robots/|robot: $PWD/config/robots/|" config/sims/forklift.yaml > "$TMP/effects.yaml"
cat >> "$TMP/effects.yaml" <<'YAML'
effects:
  time_offset: {offset_s: 0.01}
  longitudinal_slip: {slip_per_accel: 0.01}
YAML
expect_status 0 "simulate a recording with effects" \
  "$AGVCAL" simulate "$TMP/effects.yaml" "$TMP/effects.log" --trajectory demo --quiet
same_on_1_and_2 config/robots/forklift.yaml "$TMP/effects.log" effects
grep -q '"name": "time_offset"' "$TMP/effects-2.json" && pass "effects: time_offset named" || fail "effects: time_offset not named"

expect_status 2 "a bad --jobs" "$AGVCAL" diagnose config/robots/forklift.yaml logs/forklift_demo.log --jobs 0
finish
