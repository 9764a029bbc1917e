#!/usr/bin/env bash
# Calibrates every real recording of ../shared/data on the first half and compares the
# calibrated with the nominal model's odometry on the second half, window by window with a
# sign test, and says how much of the second half drove outside the first's range
# (docs/calibration.md):
#   scripts/real-data-table.sh [WORKDIR]
# Prints a Markdown table; imports into WORKDIR (default a temporary directory).
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
agvcal=${AGVCAL_BIN:-$here/build}/agvcal
work=${1:-$(mktemp -d)}
mkdir -p "$work"
robots=$here/config/robots/datasets
source "$here/scripts/dataset-robots.bash"
"$here/scripts/import-datasets.sh" "$work" > "$work/import.txt" || { cat "$work/import.txt"; exit 2; }

echo "| recording | robot file | source | parameters (nominal → calibrated ± 1σ) | held-out error per metre, nominal → calibrated | windows × length | calibrated better (sign test p) | held-out outside the fit's range | held-out half fitted alone: halves agree? |"
echo "|---|---|---|---|---|---|---|---|---|"
for log in "$work"/*.log; do
  name=$(basename "$log" .log)
  robot=$(dataset_robot "$name") || continue
  out=$work/$name.json
  solve() { "$agvcal" solve "$robots/$robot" "$log" --fit-fraction 0.5 --quiet --out "$out" "$@" \
              > "$work/$name.txt" 2> "$work/$name.err"; }
  # The time offset is estimated where the recording determines it (exit 3 names it otherwise).
  note=""
  solve --time-offset; status=$?
  if [ $status = 3 ] && grep -q "determine time_offset" "$work/$name.err"; then
    solve; status=$?; note=" (time offset not determined: 0)"
  fi
  if [ $status = 0 ]; then
    python3 - "$out" "$name" "$robot" "$note" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
src = ('lidar2d' if 'lidar2d' in r else 'pose') + sys.argv[4]
params = ', '.join(f"{k} {v['nominal']:.4g} → {v['value']:.4g} ± {v['std']:.2g}" for k, v in r['params'].items())
h = r['heldout']
p, c = h['paired'], h['motion']
def halves(h):
    a = h.get('halves')
    if not a: return 'not determined'
    e = a['heldout_fit'][a['largest']]
    return (f"{'no' if a['p'] < 0.01 else 'yes'} (p = {a['p']:.2g}; {a['largest']} {e['value']:.4g} ± {e['std']:.2g}, "
            f"{a['largest_sigmas']:.1f} σ)")
print(f"| {sys.argv[2]} | {sys.argv[3]} | {src} | {params} | "
      f"{h['nominal']['error_per_metre']:.4f} → {h['calibrated']['error_per_metre']:.4f} | "
      f"{h['calibrated']['windows']} × {h['window_m']:.2f} m | "
      f"{p['calibrated_better']} of {p['windows'] - p['ties']} (p = {p['sign_test_p']:.2g}) | "
      f"{100 * c['heldout_outside_fit']:.0f} % ({c['regressor']} {c['heldout_range'][0]:.2f}..{c['heldout_range'][1]:.2f}, "
      f"fit {c['fit_range'][0]:.2f}..{c['fit_range'][1]:.2f}) | {halves(h)} |")
PY
  else
    echo "| $name | $robot | | exit $status: $(head -c 200 "$work/$name.err" | tr '\n|' ' /') | | | | | |"
  fi
done
