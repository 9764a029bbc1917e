#!/usr/bin/env bash
# The screenshots of docs/reports.md: each command's human report (scripts/make-reports.sh) as
# headless Chromium shows it in a 1024 px window (the top 1300 px of the page), checked on the
# way (tests/tools/browser_check.py: no horizontal overflow, every image loads), written to
# docs/img/report-{diagnose,solve,ground,recal}.png.
# Usage: scripts/report-screenshots.sh [BUILD]   (default build; needs chromium)
set -eu
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$SRC/build}" && pwd)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
"$SRC/scripts/make-reports.sh" "$BUILD" "$WORK/reports"
python3 "$SRC/tests/tools/browser_check.py" --screenshots "$WORK/png" \
  diagnose="$WORK/reports/diagnose" solve="$WORK/reports/solve" ground="$WORK/reports/ground" recal="$WORK/reports/recal"
mkdir -p "$SRC/docs/img"
for name in diagnose solve ground recal; do
  size=$(stat -c %s "$WORK/png/$name.png")
  if [ "$size" -gt 262144 ]; then echo "report-screenshots: $name.png is $((size / 1024)) kB (over 256 kB)" >&2; exit 1; fi
  cp "$WORK/png/$name.png" "$SRC/docs/img/report-$name.png"
  echo "docs/img/report-$name.png ($((size / 1024)) kB)"
done
