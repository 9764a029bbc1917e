#!/usr/bin/env bash
# A scan matcher or a solver killed mid-run is restarted by the group, catches up from the
# group's recording and ends with the calibration of an undisturbed run: the sample recording
# is replayed through the group (lcm-logger, agvcal-scanmatch, agvcal-solver under supervisord,
# in a private network namespace) once undisturbed, then once per process with that process
# getting SIGKILL 8 s into the replay (about 16 s of its 29 s of robot time). Every RESULT.json
# is byte-identical to the undisturbed run's, which equals `agvcal solve`'s value for value.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log   # 29 s of robot time: about 14 s at speed 2
group() {  # group RUN_NAME: the replay through the group, in the background
  scripts/netns-run scripts/agvcal-group --replay "$log" --robot "$robot" --speed 2 \
    --run-dir "$TMP/$1" >>"$TMP/$1.out" 2>&1 &
  pid=$!
}

"$AGVCAL" solve "$robot" "$log" --quiet --out "$TMP/offline.json" >/dev/null

group undisturbed
wait "$pid"; code=$?
[ "$code" -eq 0 ] && pass "undisturbed run ends with the replay (exit 0)" || fail "undisturbed run exit $code: $(tail -3 "$TMP/undisturbed.out")"
python3 - "$TMP/offline.json" "$TMP/undisturbed/RESULT.json" <<'PY' \
  && pass "the undisturbed RESULT.json equals agvcal solve's" || fail "results differ"
import json, sys
offline, undisturbed = (json.load(open(p)) for p in sys.argv[1:3])
for k in ("params", "lidar2d", "residual", "observability"):
    assert undisturbed[k] == offline[k], ("undisturbed vs offline", k, undisturbed[k], offline[k])
print("drive_radius", undisturbed["params"]["drive_radius"], "intervals", undisturbed["residual"]["intervals"])
PY

for process in scanmatch solver; do
  run=killed_$process
  group "$run"
  sleep 8
  supervisor=$(pgrep -f "supervisord .*$TMP/$run/supervisord.conf" | head -1)
  victim=$(pgrep -P "${supervisor:-0}" -f "$BUILD/agvcal-$process" || true)
  if [ -n "$victim" ] && pgrep -f "lcm-logplayer -s 2 $SRC/$log" >/dev/null; then
    kill -KILL $victim && pass "$process killed while the replay runs (pid $victim)"
  else
    fail "no $process (or no replay) to kill: '$victim'"
  fi
  wait "$pid"; code=$?
  [ "$code" -eq 0 ] && pass "disturbed run still ends with the replay (exit 0)" || fail "disturbed run exit $code: $(tail -3 "$TMP/$run.out")"
  spawns=$(grep -c "spawned: '$process'" "$TMP/$run/supervisord.log")
  [ "$spawns" -eq 2 ] && pass "supervisord restarted $process once" || fail "$process spawned $spawns times"
  grep -q "$process exited; restarting it (1 of 3)" "$TMP/$run.out" && pass "the group reports the restart" \
    || fail "no restart message: $(tail -3 "$TMP/$run.out")"
  recovered=$(grep -o "caught up: [0-9]*" "$TMP/$run/$process.out" | tail -1 | grep -o "[0-9]*$")
  [ "${recovered:-0}" -gt 1000 ] && pass "the restarted $process read $recovered messages from the recording" \
    || fail "the restarted $process recovered ${recovered:-no} messages: $(cat "$TMP/$run/$process.out")"
  cmp "$TMP/undisturbed/RESULT.json" "$TMP/$run/RESULT.json" \
    && pass "RESULT.json with $process killed is byte-identical to the undisturbed run's" \
    || fail "RESULT.json differs: $(diff "$TMP/undisturbed/RESULT.json" "$TMP/$run/RESULT.json" | head -6)"
done
no_orphans
finish
