#!/usr/bin/env bash
# A scan matcher killed mid-run (at 8 s of the replay) is restarted by the group, catches up
# from the group's recording and matches the same scan pairs: the sample recording is replayed through
# the group (lcm-logger, agvcal-scanmatch, agvcal-solver under supervisord, in
# a private network namespace) twice; in the second run the scan matcher gets SIGKILL
# at 8 s. Both RESULT.json are byte-identical and equal `agvcal solve`'s, value for value.
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
sleep 8   # 8 s into the replay (about 16 s of its 29 s of robot time)
supervisor=$(pgrep -f "supervisord .*$TMP/killed/supervisord.conf" | head -1)
victim=$(pgrep -P "${supervisor:-0}" -f "$BUILD/agvcal-scanmatch" || true)
if [ -n "$victim" ] && pgrep -f "lcm-logplayer -s 2 $SRC/$log" >/dev/null; then
  kill -KILL $victim && pass "scan matcher killed while the replay runs (pid $victim)"
else
  fail "no scan matcher (or no replay) to kill: '$victim'"
fi
wait "$pid"; code=$?
[ "$code" -eq 0 ] && pass "disturbed run still ends with the replay (exit 0)" || fail "disturbed run exit $code: $(tail -3 "$TMP/killed.out")"
spawns=$(grep -c "spawned: 'scanmatch'" "$TMP/killed/supervisord.log")
[ "$spawns" -eq 2 ] && pass "supervisord restarted the scan matcher once" || fail "scan matcher spawned $spawns times"
grep -q "scanmatch exited; restarting it (1 of 3)" "$TMP/killed.out" && pass "the group reports the restart" \
  || fail "no restart message: $(tail -3 "$TMP/killed.out")"
recovered=$(grep -o "caught up: [0-9]*" "$TMP/killed/scanmatch.out" | tail -1 | grep -o "[0-9]*$")
[ "${recovered:-0}" -gt 1000 ] && pass "the restarted scan matcher read $recovered messages from the recording" \
  || fail "the restarted scan matcher recovered ${recovered:-no} messages: $(cat "$TMP/killed/scanmatch.out")"

cmp "$TMP/undisturbed/RESULT.json" "$TMP/killed/RESULT.json" \
  && pass "killed run's RESULT.json is byte-identical to the undisturbed run's" \
  || fail "RESULT.json differs: $(diff "$TMP/undisturbed/RESULT.json" "$TMP/killed/RESULT.json" | head -6)"
python3 - "$TMP/offline.json" "$TMP/undisturbed/RESULT.json" <<'PY' \
  && pass "the undisturbed RESULT.json equals agvcal solve's" || fail "results differ"
import json, sys
offline, undisturbed = (json.load(open(p)) for p in sys.argv[1:3])
for k in ("params", "lidar2d", "residual", "observability"):
    assert undisturbed[k] == offline[k], ("undisturbed vs offline", k, undisturbed[k], offline[k])
print("drive_radius", undisturbed["params"]["drive_radius"], "intervals", undisturbed["residual"]["intervals"])
PY
no_orphans
finish
