#!/usr/bin/env bash
# Runs `agvcal diagnose` on every real recording of ../shared/data (docs/mismatch.md):
#   scripts/mismatch-real-data.sh [WORKDIR]
# Prints a Markdown table; imports into WORKDIR (default a temporary directory) and
# leaves each REPORT.json and human report there.
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
agvcal=${AGVCAL_BIN:-$here/build}/agvcal
work=${1:-$(mktemp -d)}
mkdir -p "$work"
robots=$here/config/robots/datasets
source "$here/scripts/dataset-robots.bash"
ls "$work"/*.log > /dev/null 2>&1 || "$here/scripts/import-datasets.sh" "$work" > "$work/import.txt" || { cat "$work/import.txt"; exit 2; }

echo "| recording | source | verdict | effects found (± 1σ, p after correction) | held-out RMS where they act, before → after | held-out error by the effect's measure, before → after | not identifiable | unexplained |"
echo "|---|---|---|---|---|---|---|---|"
for log in "$work"/*.log; do
  name=$(basename "$log" .log)
  robot=$(dataset_robot "$name") || continue
  out=$work/$name.report.json
  if "$agvcal" diagnose "$robots/$robot" "$log" --quiet --out "$out" --report "$work/$name.report" \
       > "$work/$name.diag.txt" 2> "$work/$name.diag.err"; then
    python3 - "$out" "$name" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
eff = "; ".join(
    e["name"] + (f" ({e['wheel']})" if e.get("wheel") else "") + ": " +
    ", ".join(f"{k} {v['value']:.3g} ± {v['std']:.2g}" for k, v in e["params"].items()) +
    f", p {e['evidence']['p_value']:.1g}" for e in r["effects"]) or "-"
rms = "; ".join(f"{e['name']} {e['heldout_rms_before']:.3g} → {e['heldout_rms_after']:.3g} {e['heldout_component']}"
                for e in r["effects"]) or "-"
def by_measure(e):
    m = e.get("heldout_measure", "per_interval")
    if m == "drift":
        d = e["heldout_drift"]
        return f"{e['name']} {d['rms_before']:.3g} → {d['rms_after']:.3g} {d['component']} over {d['window_s']:g} s"
    if m == "stretch":
        d = e["heldout_stretch"]
        return f"{e['name']} {d['rms_before']:.3g} → {d['rms_after']:.3g} {d['component']} over {d['stretches']} stretches"
    return f"{e['name']}: per interval (the column before)"
measure = "; ".join(by_measure(e) for e in r["effects"]) or "-"
ni = ", ".join(c["name"] for c in r["candidates"] if c["status"] == "not_identifiable") or "-"
un = "; ".join(u["correlates_with"] for u in r["unexplained"]) or "-"
src = "lidar2d" if any(k.startswith("lidar2d") for k in r["calibration"]) else "pose"
print(f"| {sys.argv[2]} | {src} | {r['verdict']} | {eff} | {rms} | {measure} | {ni} | {un} |")
PY
  else
    echo "| $name | | exit $? | $(head -c 200 "$work/$name.diag.err" | tr '\n|' ' /') | | | | |"
  fi
done
