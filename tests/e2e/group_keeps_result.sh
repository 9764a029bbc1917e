#!/usr/bin/env bash
# A group run into a run directory that holds a previous RESULT.json (scripts/agvcal-group
# --run-dir): the previous calibration stays until the solver writes a new one. A run whose
# final solve fails (every SCAN with a NaN angle increment: no motion) keeps the previous
# RESULT.json byte for byte and still exits non-zero, naming the missing result; a good run
# then replaces it and exits 0 (even though its RESULT.json has the same bytes: the group tells
# a new file from the old, not new contents).
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log
run=$TMP/run
mkdir -p "$run"
"$AGVCAL" solve "$robot" "$log" --quiet --out "$run/RESULT.json" >/dev/null || fail "the previous calibration"
previous=$(sha256sum <"$run/RESULT.json")

python3 tests/tools/corrupt_log.py $log "$TMP/noscan.log" SCAN all 20 =0x7fc00000
group() {  # group NAME RECORDING: the replay through the group, into the one run directory
  scripts/netns-run scripts/agvcal-group --replay "$2" --robot "$robot" --speed 2 \
    --run-dir "$run" --log "$TMP/$1.recording.log" >"$TMP/$1.out" 2>&1
}
group noscan "$TMP/noscan.log"; code=$?
[ "$code" -eq 1 ] && pass "a failed final solve: the group fails (exit 1)" || fail "failed solve: group exit $code: $(tail -3 "$TMP/noscan.out")"
grep -q "the solver wrote no RESULT.json" "$TMP/noscan.out" && pass "the group names the missing result" ||
  fail "group said: $(tail -3 "$TMP/noscan.out")"
[ -s "$run/RESULT.json" ] && [ "$(sha256sum <"$run/RESULT.json")" = "$previous" ] &&
  pass "the previous RESULT.json is kept, byte for byte" || fail "the previous RESULT.json is gone or changed"

group good "$log"; code=$?
[ "$code" -eq 0 ] && pass "a good run over a previous RESULT.json: exit 0" || fail "good run: exit $code: $(tail -3 "$TMP/good.out")"
grep -q '"params"' "$run/RESULT.json" && pass "RESULT.json written" || fail "no RESULT.json"
no_orphans
finish
