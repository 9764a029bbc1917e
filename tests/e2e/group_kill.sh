#!/usr/bin/env bash
# A scan matcher or a solver killed mid-run is restarted by the group, catches up from the
# group's recording and ends with the calibration of an undisturbed run: the sample recording
# is replayed through the group (lcm-logger, agvcal-scanmatch, agvcal-solver under supervisord,
# in a private network namespace) once undisturbed, then once per process with that process
# getting SIGKILL once the recording holds 1100 wheel states (11 s of its 29 s of robot time:
# the test waits for that state, not for a time, and kills at once: processes are found in
# /proc, not through supervisorctl, whose start a loaded machine stretches to seconds). Every
# RESULT.json is byte-identical to the undisturbed run's, which equals `agvcal solve`'s value
# for value.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log   # 29 s of robot time: about 14 s at speed 2
group() {  # group RUN_NAME: the replay through the group, in the background
  scripts/netns-run scripts/agvcal-group --replay "$log" --robot "$robot" --speed 2 \
    --run-dir "$TMP/$1" >>"$TMP/$1.out" 2>&1 &
  pid=$!
}

# kill_while_replaying PROCESS: SIGKILL to the group's PROCESS, and a check that the replay
# was still running after it (so it was killed mid-replay).
kill_while_replaying() {
  local victim
  victim=$(test_pgrep "$BUILD/agvcal-$1 ")
  if [ -z "$victim" ]; then fail "no $1 to kill"; return; fi
  kill -KILL $victim
  if [ -n "$(test_pgrep "lcm-logplayer ")" ]; then pass "$1 killed while the replay runs (pid $victim)"
  else fail "$1 killed (pid $victim) after the replay had ended"; fi
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
  wait_for 120 "1100 wheel states recorded" at_least 1100 recorded WHEELS "$TMP/$run/recording.log"
  kill_while_replaying "$process"
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

# The logger killed while writing an event (stopped, part of an event added to the file as a
# write cut short leaves it, then SIGKILL: its buffered writes are lost), later the solver:
# the restarted logger cuts the torn event off before it appends, so the recording reads
# whole and the restarted solver catches up through it and writes RESULT.json.
run=killed_logger
group "$run"
rec=$TMP/$run/recording.log
wait_for 120 "1000 wheel states recorded" at_least 1000 recorded WHEELS "$rec"
lcm_logger=$(test_pgrep "^lcm-logger -q -a ")
if [ -n "$lcm_logger" ] && kill -STOP "$lcm_logger"; then
  # What the stopped logger wrote ends with a whole event (its own buffered tail cut off), then
  # 20 bytes of the first event's header: a torn event, whatever the logger's buffer held.
  "$BUILD/agvcal-recording" repair "$rec" 2>/dev/null
  head -c 20 "$rec" >"$TMP/torn" && cat "$TMP/torn" >>"$rec"
  kill -KILL "$lcm_logger" && pass "lcm-logger killed with a torn event at the end of the recording"
else
  fail "no lcm-logger to kill"
fi
at_kill=$(recorded WHEELS "$rec")
wait_for 120 "the restarted logger recording" at_least $((at_kill + 200)) recorded WHEELS "$rec"
kill_while_replaying solver
wait "$pid"; code=$?
[ "$code" -eq 0 ] && pass "the run ends with the replay (exit 0)" || fail "run exit $code: $(tail -3 "$TMP/$run.out")"
grep -q "cut a torn last event (20 bytes" "$TMP/$run/logger.out" && pass "the restarted logger cut the torn event" \
  || fail "logger.out: $(cat "$TMP/$run/logger.out")"
expect_status 0 "the recording reads whole from start to end" "$AGVCAL" info "$rec"
grep -q "the logger was restarted 1 time" "$TMP/$run.out" && pass "the group names the recording's gap" \
  || fail "no word about the gap: $(tail -3 "$TMP/$run.out")"
spawns=$(grep -c "spawned: 'solver'" "$TMP/$run/supervisord.log")
[ "$spawns" -eq 2 ] && pass "the solver restarted once (did not die catching up)" || fail "solver spawned $spawns times: $(tail -5 "$TMP/$run/solver.out")"
[ -s "$TMP/$run/RESULT.json" ] && pass "RESULT.json written" || fail "no RESULT.json: $(tail -3 "$TMP/$run.out")"
no_orphans
finish
