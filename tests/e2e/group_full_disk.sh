#!/usr/bin/env bash
# A full disk during a live run ends the group mid-trajectory, with one line saying so,
# and nothing is restarted into it: the simulated forklift's group runs with its run
# directory on a 20 MB tmpfs of its own (a private mount namespace), 19 MB of it taken
# beforehand, so that the recording fills it a few seconds into the trajectory. The run
# directory holds the previous calibration's RESULT.json, which must come out byte for byte.
source "$(dirname "$0")/lib.bash" "$@"
mkdir "$TMP/disk"
"$AGVCAL" solve config/robots/forklift.yaml logs/forklift_demo.log --quiet --out "$TMP/previous.json" >/dev/null ||
  fail "the previous calibration"
cat >"$TMP/full.sh" <<SCRIPT
mount -t tmpfs -o size=20m agvcal-test-disk "$TMP/disk" || exit 99
mkdir "$TMP/disk/run" && cp "$TMP/previous.json" "$TMP/disk/run/RESULT.json"
head -c 19M /dev/zero >"$TMP/disk/filler"
start=\$(date +%s%N)
scripts/agvcal-group --sim config/sims/forklift.yaml --trajectory default --speed 2 \
  --run-dir "$TMP/disk/run" >"$TMP/group.out" 2>&1
echo "\$? \$(( (\$(date +%s%N) - start) / 1000000 ))" >"$TMP/ended"
cp -r "$TMP/disk/run" "$TMP/run"   # the tmpfs goes with the namespace
SCRIPT
timeout 120 unshare -m bash "$TMP/full.sh"
read -r code ms <"$TMP/ended" || { code=none ms=0; }
[ "$code" = 1 ] && pass "the group exits 1 on a full disk" || fail "group exit $code: $(tail -5 "$TMP/group.out")"
# It ended mid-trajectory, whatever the load made of the time (an undisturbed run of this
# trajectory takes about 40 s at --speed 2): the commander did not finish (its output, on the
# full disk, may lack its last line; the group's, beside it, says when the commander is done).
if ! grep -q "trajectory finished" "$TMP/run/commander.out" 2>/dev/null &&
  ! grep -q "agvcal-group: commander: done" "$TMP/group.out"; then
  pass "it ended mid-trajectory, $ms ms after it started"
else
  fail "the commander finished its trajectory ($ms ms): $(tail -3 "$TMP/group.out")"
fi
grep -q "^agvcal-group: the disk of .* is full (.* kB free); see " "$TMP/group.out" \
  && pass "one line says the disk is full" || fail "group.out: $(tail -5 "$TMP/group.out")"
# Only the group's own lines: no Python traceback from supervisord's log on the full disk.
others=$(grep -vc "^agvcal-group: " "$TMP/group.out")
[ "$others" -eq 0 ] && pass "only agvcal-group's own lines" || fail "$others other lines: $(grep -m 6 -v "^agvcal-group: " "$TMP/group.out")"
spawns=$(grep -c "spawned: 'logger'" "$TMP/run/supervisord.log" 2>/dev/null)
[ "${spawns:-0}" -eq 1 ] && pass "the logger was not restarted into the full disk" || fail "logger spawned $spawns times"
cmp -s "$TMP/previous.json" "$TMP/run/RESULT.json" && pass "the previous RESULT.json is kept, byte for byte" ||
  fail "the previous RESULT.json is gone or changed"
no_orphans
finish
