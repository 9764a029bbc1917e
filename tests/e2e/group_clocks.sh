#!/usr/bin/env bash
# Two clocks in one group (issue 17 item 8): the sample recording with every SCAN stamped one
# hour later (its utime field; the log's own timestamps, and so the replay's pace, unchanged),
# as when one bridge stamps on a recording's clock and another on the host's, replayed through
# scripts/agvcal-group in a private network namespace. The scan matcher says so in one line as
# soon as the streams meet, is not restarted, and the group's failure names the cause.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log
python3 tests/tools/corrupt_log.py $log "$TMP/clocks.log" SCAN all 8 +3600000000
scripts/netns-run scripts/agvcal-group --replay "$TMP/clocks.log" --robot "$robot" --speed 2 \
  --run-dir "$TMP/clocks" >"$TMP/clocks.out" 2>&1; code=$?
[ "$code" -ne 0 ] && pass "no motion, no result: the group exits non-zero ($code)" || fail "group exit 0"
said=$(grep -c 'two clock domains' "$TMP/clocks/scanmatch.out")
[ "$said" -eq 1 ] && pass "the scan matcher says it once" || fail "said $said times: $(cat "$TMP/clocks/scanmatch.out")"
grep -q "agvcal-scanmatch: scan and wheel stamps are 3600 s apart" "$TMP/clocks/scanmatch.out" &&
  pass "with the size of the gap" || fail "scanmatch.out: $(cat "$TMP/clocks/scanmatch.out")"
# At start: among its first three lines (what it matches, the catch-up, this).
head -3 "$TMP/clocks/scanmatch.out" | grep -q 'two clock domains' && pass "at start" ||
  fail "not at start: $(head -3 "$TMP/clocks/scanmatch.out")"
spawns=$(grep -c "spawned: 'scanmatch'" "$TMP/clocks/supervisord.log")
[ "$spawns" -eq 1 ] && pass "the scan matcher was never restarted" || fail "scanmatch spawned $spawns times"
grep -q "restart" "$TMP/clocks.out" && fail "restarts: $(grep restart "$TMP/clocks.out")" || pass "no restarts in the group"
tail -1 "$TMP/clocks.out" | grep -q "two clock domains" && pass "the group's last line names the cause" ||
  fail "group's last line: $(tail -1 "$TMP/clocks.out")"
no_orphans
finish
