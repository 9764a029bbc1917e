#!/usr/bin/env bash
# What a person reads (offline commands): units on printed numbers (solve's table, diagnose's
# summary), p-values never "p = 0", progress without carriage returns into a file, result and
# report paths checked before the analysis (exit 2 naming the path), a reused report folder
# replaced whole or, holding the user's files, refused, and diagnose refusing a straight-only recording as solve does.
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml
log=logs/forklift_demo.log

# solve's table: every parameter with its unit, angles in rad with degrees beside; the yaw
# residual in mrad (docs/units.md).
expect_status 0 "solve" "$AGVCAL" solve $robot $log --quiet
python3 - "$TMP/stdout" <<'PY' && pass "solve's table has units, rad with deg beside" || fail "solve's table: $(cat "$TMP/stdout")"
import re, sys
text = open(sys.argv[1]).read()
assert re.search(r"residual rms x [0-9.]+ mm, y [0-9.]+ mm, yaw [0-9.]+ mrad \([0-9.e-]+ deg\)", text), text
rows = {m.group(1): m.group(2) for m in re.finditer(r"^  (\S+) +(-?[0-9].*?) +\(nominal", text, re.M)}
assert set(rows) >= {"drive_radius", "wheelbase", "steer_offset", "lidar2d.x", "lidar2d.yaw"}, rows
for name in ("drive_radius", "wheelbase", "lidar2d.x"):
    assert re.fullmatch(r"-?[0-9.]+ ± [0-9.]+ m", rows[name]), (name, rows[name])
for name in ("steer_offset", "lidar2d.yaw"):
    assert re.fullmatch(r"-?[0-9.]+ ± [0-9.]+ rad \(-?[0-9.]+ ± [0-9.]+ deg\)", rows[name]), (name, rows[name])
PY

# diagnose's summary: units on the overall lines, p-values with two digits or "< 1e-12".
expect_status 0 "diagnose" "$AGVCAL" diagnose $robot $log --quiet --report "$TMP/report"
python3 - "$TMP/report/summary.txt" <<'PY' && pass "summary.txt has units" || fail "summary.txt: $(cat "$TMP/report/summary.txt")"
import re, sys
text = open(sys.argv[1]).read()
assert re.search(r"Overall held-out residual RMS: x [0-9.]+ mm -> [0-9.]+ mm, y [0-9.]+ mm -> [0-9.]+ mm, "
                 r"yaw [0-9.]+ mrad \([0-9.e-]+ deg\) -> [0-9.]+ mrad", text), text
assert re.search(r"translation [0-9.]+ mm -> [0-9.]+ mm, heading [0-9.]+ mrad \(", text), text
assert not re.search(r"p = 0(?![.0-9])|p = 0\.0+(?![0-9])", text), text  # "p = 0", "p = 0.000"
assert "+-" not in text, text
PY

# One vocabulary (docs/units.md): the parameters in one order in solve's console table, solve's page
# and diagnose's page; the yaw residual in mrad on every one of them and in both summary.txt.
expect_status 0 "solve --report" "$AGVCAL" solve $robot $log --quiet --report "$TMP/solve_page"
cp "$TMP/stdout" "$TMP/solve_console.txt"
python3 - "$TMP/solve_console.txt" "$TMP/solve_page" "$TMP/report" <<'PY' && pass "one order and one yaw unit across solve and diagnose" || fail "order or units differ"
import html, re, sys
console, solve, diagnose = sys.argv[1:4]
def page_rows(path):
    text = open(path + "/index.html", encoding="utf-8").read()
    table = re.search(r"<tr><th>parameter</th>.*?</table>", text, re.S)
    assert table, path + ": no table headed 'parameter'"
    return [html.unescape(n) for n in re.findall(r"<tr><td>([^<]+)</td>", table.group(0))], text
order = re.findall(r"^  (\S+) +-?[0-9].*\(nominal", open(console).read(), re.M)
solve_order, solve_text = page_rows(solve)
diagnose_order, diagnose_text = page_rows(diagnose)
print("console:", order, "\nsolve page:", solve_order, "\ndiagnose page:", diagnose_order)
assert order and order == solve_order == diagnose_order
for name, text in (("solve", solve_text), ("diagnose", diagnose_text)):
    summary = open({"solve": solve, "diagnose": diagnose}[name] + "/summary.txt", encoding="utf-8").read()
    assert re.search(r"yaw [0-9.]+ mrad", summary), name + " summary.txt: yaw residual not in mrad"
    assert not re.search(r"yaw (residual )?[0-9.e-]+ (rad|deg)\b", summary), name + " summary.txt: yaw residual in rad or deg"
    plot = open({"solve": solve, "diagnose": diagnose}[name] + "/residual_time.svg", encoding="utf-8").read()
    assert "yaw residual (mrad)" in plot, name + " page: the yaw residual plot is not in mrad"
PY

# Summary lines of a found effect and of a candidate the recording cannot identify.
cat >"$TMP/slip.yaml" <<SIM
robot: $SRC/config/robots/diff_robot.yaml
effects:
  longitudinal_slip: {slip_per_accel: 0.02}
SIM
"$AGVCAL" simulate "$TMP/slip.yaml" "$TMP/slip.log" --trajectory demo 2>"$TMP/progress"
if ! grep -q $'\r' "$TMP/progress" && grep -q "^simulated [0-9.]* s, [0-9]* messages" "$TMP/progress"; then
  pass "simulate: progress into a file as lines, no carriage returns"
else fail "simulate's progress: $(od -c "$TMP/progress" | head -5)"; fi
expect_status 0 "diagnose (slip)" "$AGVCAL" diagnose config/robots/diff_robot.yaml "$TMP/slip.log" --quiet
python3 - "$TMP/stdout" <<'PY' && pass "effect size in s²/m, p-value readable, detectable size with a unit" || fail "slip summary: $(cat "$TMP/stdout")"
import re, sys
text = open(sys.argv[1]).read()
assert re.search(r"slip_per_accel = [0-9.]+ ± [0-9.]+ s²/m", text), text
assert re.search(r"evidence: p (< 1e-12|= [0-9.e-]+) after", text), text
for m in re.finditer(r"could only detect it above (\S+) (\S+)", text):
    assert m.group(2).rstrip(";") in ("s", "s²/m", "rad", "rad/s", "(relative)"), m.group(0)
assert not re.search(r"could only detect it above [0-9.e-]+;", text), "a detectable size without unit"
PY

# Every number true: with 70 % fitted the forklift sample holds fewer held-out intervals than
# --heldout-windows; the windows are no shorter than its longest interval, not "of 0.00 m".
expect_status 0 "solve --fit-fraction 0.7 --report --out --write-robot" "$AGVCAL" solve $robot $log --quiet \
  --fit-fraction 0.7 --report "$TMP/solve" --out "$TMP/solve.json" --write-robot "$TMP/calibrated.yaml"
cp "$TMP/stdout" "$TMP/solve.out"
python3 - "$TMP/solve.out" <<'PY' && pass "held-out windows of a true path length" || fail "held-out windows: $(grep windows "$TMP/solve.out")"
import re, sys
m = re.search(r"\((\d+) windows of ([0-9.]+) m\)", open(sys.argv[1]).read())
assert m and float(m.group(2)) >= 0.05, m and m.group(0)
PY
# The differential sample's held-out 30 % cannot determine the track alone: no "halves disagree".
expect_status 0 "solve diff_robot --fit-fraction 0.7" "$AGVCAL" solve config/robots/diff_robot.yaml \
  logs/diff_robot_demo.log --quiet --fit-fraction 0.7
if ! grep -q "halves disagree" "$TMP/stdout" && grep -q "the halves are not compared: .*cannot determine .*track" "$TMP/stdout"; then
  pass "no false alarm: the halves not compared on a value the held-out half cannot determine"
else fail "halves: $(grep -A2 halves "$TMP/stdout")"; fi

# Every output says what produced it, and opens with a verdict.
sha=$(sha256sum $log | cut -c1-64)
python3 - "$TMP/solve.out" "$TMP/solve/summary.txt" "$TMP/solve.json" "$TMP/calibrated.yaml" "$sha" "$AGVCAL" <<'PY' \
  && pass "provenance in summary.txt, RESULT.json and the written robot file; the verdict first" \
  || fail "provenance or verdict missing"
import json, re, subprocess, sys
out, summary, result, robot, sha, agvcal = sys.argv[1:7]
version = subprocess.run([agvcal, "--version"], capture_output=True, text=True).stdout.split(" ", 1)[1].strip()
first = open(out).read().split("\n")[0]
assert first.startswith("Write the calibration") or first.startswith("Calibrated, but") or \
    first.startswith("The calibration is not") or first.startswith("Check before"), first
text = open(summary).read()
for line in ("robot_name: forklift-07", "robot_file: config/robots/forklift.yaml", "recording: logs/forklift_demo.log",
             "recording_sha256: " + sha, "agvcal_version: " + version):
    assert "\n" + line + "\n" in "\n" + text, (line, text)
assert re.search(r"^command: \S*agvcal solve config/robots/forklift.yaml logs/forklift_demo.log .*--fit-fraction 0.7", text, re.M), text
assert re.search(r"^date: \d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ$", text, re.M), text
assert text.split("\n\n", 1)[1].startswith(first), (first, text)
p = json.load(open(result))["provenance"]
assert p["recording_sha256"] == sha and p["robot_name"] == "forklift-07" and p["agvcal_version"] == version, p
yaml = open(robot).read()
assert "nominal values" not in yaml, yaml
assert "#   recording_sha256: " + sha in yaml, yaml
assert re.search(r"#   fitted on the first (\d+) of (\d+) usable intervals \((6[0-9]|7[0-9]) %\)", yaml), yaml
PY

# The diagnosis's bookkeeping stays off the console (and REPORT.json keeps it) unless --verbose.
expect_status 0 "diagnose" "$AGVCAL" diagnose $robot $log --quiet --out "$TMP/diag.json"
if ! grep -qE "log SSE|^note: |not_significant|boxes of the route \(x 0 \.\. 0" "$TMP/stdout" &&
   grep -q "log SSE" "$TMP/diag.json"; then
  pass "no internal notes on the console; REPORT.json keeps them"
else fail "diagnose console: $(grep -E "log SSE|^note: |not_significant" "$TMP/stdout" | head -3)"; fi
expect_status 0 "diagnose --verbose" "$AGVCAL" diagnose $robot $log --quiet --verbose
grep -q "^note: actuation: .*log SSE" "$TMP/stdout" && pass "--verbose prints the notes" || fail "--verbose: no notes"

# Paths checked before the analysis: exit 2 at once, naming the path, no progress printed.
touch "$TMP/a_file"
expect_status 2 "--report at an existing file" "$AGVCAL" diagnose $robot $log --report "$TMP/a_file"
stderr_has "$TMP/a_file"
if ! grep -q "baseline calibration\|matching" "$TMP/stderr"; then pass "refused before the analysis"; else fail "analysis ran first: $(head -c 300 "$TMP/stderr")"; fi
expect_status 2 "--report below a file" "$AGVCAL" diagnose $robot $log --report "$TMP/a_file/report" --quiet
stderr_has "$TMP/a_file/report"
expect_status 2 "--out in a missing folder" "$AGVCAL" solve $robot $log --out "$TMP/none/r.json" --quiet
stderr_has "$TMP/none/r.json"

# A reused report folder: agvcal's own earlier report is replaced whole (its manifest lists
# every file it wrote); a folder holding anything else (the user's notes, a figure agvcal did
# not write) is refused, exit 2 naming the file, and nothing in it is touched.
expect_status 0 "diagnose into its own earlier report" "$AGVCAL" diagnose $robot $log --quiet --report "$TMP/report"
[ -e "$TMP/report/residual_time.svg" ] && [ -e "$TMP/report/.agvcal-report" ] && pass "the earlier report replaced" ||
  fail "report folder: $(ls -A "$TMP/report")"
echo '<svg/>' >"$TMP/report/signature_9_stale.svg"
echo 'mine' >"$TMP/report/notes.md"
expect_status 2 "diagnose into a report folder with the user's files" "$AGVCAL" diagnose $robot $log --quiet --report "$TMP/report"
stderr_has "was not written by agvcal"
if [ -e "$TMP/report/signature_9_stale.svg" ] && [ "$(cat "$TMP/report/notes.md")" = mine ] && [ -e "$TMP/report/residual_time.svg" ]; then
  pass "the user's files and the earlier report untouched"
else fail "report folder: $(ls -A "$TMP/report")"; fi

# A straight-only recording: diagnose refuses like solve (exit 3), naming what and the motion.
"$AGVCAL" simulate config/sims/diff_robot.yaml "$TMP/straight.log" --trajectory straight --quiet
expect_status 3 "diagnose on a straight-only recording" \
  "$AGVCAL" diagnose config/robots/diff_robot.yaml "$TMP/straight.log" --quiet --out "$TMP/no.json"
stderr_has "track"
stderr_has "cannot be made"
if [ ! -e "$TMP/no.json" ]; then pass "no REPORT.json on exit 3"; else fail "REPORT.json written on exit 3"; fi
finish
