#!/usr/bin/env bash
# A solver killed mid-run is restarted by the group and ends with the
# calibration of an undisturbed run: the sample recording is replayed through
# the group (lcm-logger, agvcal-scanmatch, agvcal-solver under supervisord, in
# a private network namespace) twice; in the second run the solver gets SIGKILL
# halfway. Both RESULT.json equal `agvcal solve`'s, value for value.
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

group killed
sleep 7   # about halfway through the replay
victim=$(pgrep -f "$BUILD/agvcal-solver .*$TMP/killed" || true)
if [ -n "$victim" ] && pgrep -f "lcm-logplayer -s 2 $SRC/$log" >/dev/null; then
  kill -KILL $victim && pass "solver killed while the replay runs (pid $victim)"
else
  fail "no solver (or no replay) to kill: '$victim'"
fi
wait "$pid"; code=$?
[ "$code" -eq 0 ] && pass "disturbed run still ends with the replay (exit 0)" || fail "disturbed run exit $code: $(tail -3 "$TMP/killed.out")"
spawns=$(grep -c "spawned: 'solver'" "$TMP/killed/supervisord.log")
[ "$spawns" -eq 2 ] && pass "supervisord restarted the solver once" || fail "solver spawned $spawns times"
grep -q "solver exited; restarting it (1 of 3)" "$TMP/killed.out" && pass "the group reports the restart" \
  || fail "no restart message: $(tail -3 "$TMP/killed.out")"
recovered=$(grep -o "caught up: [0-9]*" "$TMP/killed/solver.out" | tail -1 | grep -o "[0-9]*$")
[ "${recovered:-0}" -gt 1000 ] && pass "the restarted solver read $recovered messages from the recording" \
  || fail "the restarted solver recovered ${recovered:-no} messages: $(cat "$TMP/killed/solver.out")"

python3 - "$TMP/offline.json" "$TMP/undisturbed/RESULT.json" "$TMP/killed/RESULT.json" <<'PY' \
  && pass "killed run's RESULT.json equals the undisturbed run's and agvcal solve's" \
  || fail "results differ"
import json, sys
offline, undisturbed, killed = (json.load(open(p)) for p in sys.argv[1:4])
for k in ("params", "lidar2d", "residual", "observability"):
    assert killed[k] == undisturbed[k], ("killed vs undisturbed", k, killed[k], undisturbed[k])
    assert undisturbed[k] == offline[k], ("undisturbed vs offline", k, undisturbed[k], offline[k])
print("drive_radius", killed["params"]["drive_radius"], "intervals", killed["residual"]["intervals"])
PY
no_orphans
finish
