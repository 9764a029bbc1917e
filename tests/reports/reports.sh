#!/usr/bin/env bash
# The human reports of diagnose, solve, ground and recal (docs/reports.md): written by
# scripts/make-reports.sh into BUILD/reports (kept for the browser test, reports_browser), each
# folder well-formed (tests/tools/check_report_dir.py: XML of every SVG, the page shows every
# plot, tables with data, no <pre>), the plots each command promises, the candidates table and
# the actuation close-up of the diagnosis, times since the recording's first message in
# the pages; a report folder that is a file exits 2 before any work; a reused folder loses the
# previous report's plots, a folder holding someone else's index.html is refused (exit 2).
# Usage: reports.sh BUILD SRC
set -u
BUILD=$(cd "${1:?build dir}" && pwd)
SRC=$(cd "${2:?source dir}" && pwd)
cd "$SRC"
fails=0
fail() { echo "FAIL $*"; fails=$((fails + 1)); }
pass() { echo "PASS $*"; }
OUT=$BUILD/reports
rm -rf "$OUT"
if scripts/make-reports.sh "$BUILD" "$OUT"; then pass "reports written"; else fail "scripts/make-reports.sh"; fi
check() { if python3 tests/tools/check_report_dir.py "$@"; then pass "$1 well-formed"; else fail "$1"; fi; }
check "$OUT/diagnose" residual_time.svg route.svg actuation_zoom_speed_drive.svg "text:Every candidate of the catalogue" \
  "text:drive_lag" "text:baseline" "text:since the recording's first message" "text:s²/m"
check "$OUT/solve" residual_time.svg residual_histogram.svg heldout_windows.svg route.svg "text:Observability" \
  "text:Condition number" "text:calibrated ± 1σ" "text: mm" "text:since the recording's first message"
check "$OUT/ground" floor_points.svg floor_height_histogram.svg frames.svg "text:lidar3d.pitch" "text: deg"
check "$OUT/recal" heldout_segments.svg residual_time.svg "text:Decisions" "text:accepted" "text:rejected"
# The legends: held-out spans and the effect's own spans never share one.
if grep -q "effect stands out" "$OUT"/solve/*.svg "$OUT"/recal/*.svg; then fail "a calibration plot says 'effect stands out'"; else pass "calibration plots: held-out legend only"; fi
if grep -l "held out (not fitted)" "$OUT"/solve/residual_time.svg >/dev/null; then pass "solve: held-out spans named"; else fail "solve: held-out spans unnamed"; fi
if grep -q "recording's first message" "$OUT"/diagnose/residual_time.svg; then pass "time axis says its origin"; else fail "time axis lacks its origin"; fi

# A report folder that is a file: exit 2 at once, naming it.
: > "$BUILD/reports-file"
"$BUILD/agvcal" solve config/robots/forklift.yaml logs/forklift_demo.log --quiet --report "$BUILD/reports-file" 2> "$BUILD/reports-err"
status=$?
if [ $status -eq 2 ] && grep -q "reports-file" "$BUILD/reports-err"; then pass "report at a file: exit 2"; else fail "report at a file: exit $status: $(cat "$BUILD/reports-err")"; fi
rm -f "$BUILD/reports-file" "$BUILD/reports-err"
# A reused folder: the previous report's plots are gone; someone else's page is left alone (exit 2).
rm -rf "$BUILD/reports-reused" && cp -r "$OUT/solve" "$BUILD/reports-reused"
"$BUILD/agvcal" ground config/robots/forklift.yaml "$OUT/work/clouds.log" --quiet --report "$BUILD/reports-reused"
if [ ! -e "$BUILD/reports-reused/residual_time.svg" ] && [ -s "$BUILD/reports-reused/floor_points.svg" ]; then
  pass "reused folder cleared of the old plots"; else fail "reused folder keeps the old plots: $(ls "$BUILD/reports-reused")"; fi
echo '<html><title>my page</title></html>' > "$BUILD/reports-reused/index.html"
"$BUILD/agvcal" ground config/robots/forklift.yaml "$OUT/work/clouds.log" --quiet --report "$BUILD/reports-reused" 2> "$BUILD/reports-err"
status=$?
if [ $status -eq 2 ] && grep -q "my page" "$BUILD/reports-reused/index.html" && [ -s "$BUILD/reports-reused/floor_points.svg" ]; then
  pass "a folder with another page: exit 2, nothing removed"; else fail "a folder with another page: exit $status: $(cat "$BUILD/reports-err")"; fi
rm -rf "$BUILD/reports-reused" "$BUILD/reports-err"
echo "failures: $fails"
[ $fails -eq 0 ]
