#!/usr/bin/env bash
# `agvcal diagnose` end to end: REPORT.json with the keys of spec/cli.md, the human report,
# a simulation config the simulator accepts, --sim, bad input (exit 2), and a CI-sized run
# of the concealed-effect suite (scripts/mismatch-suite.sh --quick).
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log

expect_status 0 "diagnose --help" "$AGVCAL" diagnose --help
# The sample with one wheel state damaged (its position +100 rad): left out, and said in REPORT.json.
python3 tests/tools/wheel_log.py $log "$TMP/jump.log" 1000 position drive 100
expect_status 0 "diagnose the sample (one wheel state jumps)" \
  "$AGVCAL" diagnose "$robot" "$TMP/jump.log" --quiet --out "$TMP/report.json" --report "$TMP/report" \
  --write-sim "$TMP/reproduce.yaml" --sim "$log"
stderr_has "1 message(s) of $TMP/jump.log left out of the diagnosis"  # said with --quiet too
python3 - "$TMP/report.json" <<'PY' && pass "REPORT.json has the keys of spec/cli.md, and input names the left-out wheel state" || fail "REPORT.json keys"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["input"]["dropped"] == 1 and "(WHEELS): wheel 'drive' position jumps" in r["input"]["notes"][0], r.get("input")
assert r["verdict"] in ("effects_found", "no_significant_effect", "unmodelled_structure")
assert isinstance(r["effects"], list) and isinstance(r["unexplained"], list) and isinstance(r["discovered"], list)
for e in r["effects"]:
    for k in ("name", "params", "evidence", "heldout_rms_before", "heldout_rms_after", "where"):
        assert k in e, k
    assert "delta_bic" in e["evidence"] and "p_value" in e["evidence"]
assert r["intervals"] and all("motion" in i for i in r["intervals"])
assert "sim_comparison" in r and "params" in r["sim_comparison"]
PY
for f in summary.txt index.html residual_time.svg route.svg; do
  if [ -s "$TMP/report/$f" ]; then pass "report has $f"; else fail "report lacks $f"; fi
done
expect_status 0 "the written sim config runs" "$AGVCAL" simulate "$TMP/reproduce.yaml" "$TMP/again.log" --trajectory demo --quiet
expect_status 2 "a missing log" "$AGVCAL" diagnose "$robot" "$TMP/nothing.log" --quiet
stderr_has "nothing.log"
expect_status 2 "an unknown option" "$AGVCAL" diagnose "$robot" "$log" --bogus
expect_status 2 "a bad --alpha" "$AGVCAL" diagnose "$robot" "$log" --alpha 2
if [ -e "$TMP/report.partial.json" ]; then fail "partial file left"; else pass "no partial file"; fi

# The suite, CI size: controls name nothing, single effects are named right. The bound is for a
# hang only (the test's ctest TIMEOUT is above it): a loaded machine makes the suite slow, not wrong.
expect_status 0 "mismatch suite (quick)" \
  timeout 1500 scripts/mismatch-suite.sh --build "$BUILD" --quick --seeds 1 --controls 1 --jobs 2 \
  --work "$TMP/suite" --json "$TMP/suite.json"
python3 - "$TMP/suite.json" <<'PY' && pass "suite: controls clean, effects named" || fail "suite: $(cat "$TMP/suite.json" | head -c 1500)"
import json, sys
rows = json.load(open(sys.argv[1]))
for row in rows:
    if row["truth"] in ("none", "noisy") or row["truth"].startswith("unexcited"):
        assert row["other_named"] == 0, row
    elif row["truth"] in ("longitudinal_slip", "steering_backlash"):
        assert row["named_correctly"] == row["runs"], row
PY
finish
