#!/usr/bin/env bash
# `solve --write-robot` and `ground --write-robot` (offline): the written robot file keeps the
# input's comments and layout (but for the "nominal values" note), says what produced it, each value is rounded to its sigma (no 17-digit floats) and
# within that rounding of RESULT.json's estimate, it reads back, and the std: and source: keys
# are there. Ground writes lidar3d in the robot file's units (m, rad).
source "$(dirname "$0")/lib.bash" "$@"
robot=config/robots/forklift.yaml

check_written() {  # check_written INPUT.yaml WRITTEN.yaml RESULT.json SECTION...: python checks
  python3 - "$@" <<'PY'
import json, re, sys
src, out, result = open(sys.argv[1]).read(), open(sys.argv[2]).read(), json.load(open(sys.argv[3]))
for line in src.splitlines():
    header_line = line.startswith("# Calibrated by agvcal ") or line.startswith("#   ")  # replaced by the new header
    if "#" in line and not header_line and "nominal values" not in line:
        assert line[line.index("#"):] in out, "comment lost: " + line
assert "nominal values" not in out, "the values are calibrated, not nominal:\n" + out
# The header's provenance and fitted-fraction lines ("#   ...") come on top of the layout.
header = sum(1 for line in out.splitlines() if line.startswith("#   "))
assert header >= 8, "no provenance in the header:\n" + out
assert len(out.splitlines()) - header <= len(src.splitlines()) + 6, "layout changed:\n" + out
assert out.startswith("# Calibrated by agvcal "), out
for section in sys.argv[4:]:
    for key, e in result[section].items():
        if not isinstance(e, dict) or "std" not in e or not e["std"]:
            continue
        name = key if section != "params" else key
        m = re.search(r"\b%s: (-?[0-9.]+)" % re.escape(name), out[out.index(section + ":"):] if section != "params" else out)
        assert m, (section, key)
        text = m.group(1)
        decimals = len(text.split(".")[1]) if "." in text else 0
        assert len(text) < 12, (key, text)
        assert abs(float(text) - e["value"]) <= 0.5 * 10 ** -decimals + 1e-12, (key, text, e["value"])
        assert 10 ** -decimals <= e["std"] / 9, (key, text, e["std"], "rounded to 2 digits of the sigma")
assert "\nstd:\n" in out and "\nsource: " in out, out
PY
}

expect_status 0 "solve --write-robot" \
  "$AGVCAL" solve "$robot" logs/forklift_demo.log --quiet --out "$TMP/solve.json" --write-robot "$TMP/cal.yaml"
check_written "$robot" "$TMP/cal.yaml" "$TMP/solve.json" params lidar2d \
  && pass "solve's robot file: comments kept, values rounded to their sigma" || fail "solve's robot file: $(cat "$TMP/cal.yaml")"
expect_status 0 "the written robot file reads back" "$AGVCAL" solve "$TMP/cal.yaml" logs/forklift_demo.log --quiet

cat >"$TMP/sim3d.yaml" <<SIM
robot: $SRC/config/robots/forklift.yaml
truth:
  lidar3d: {z: 1.912, pitch: 0.035, roll: -0.012}
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 0}
  lidar3d: {rate: 1, rings: 16, points_per_ring: 360, body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]}}
SIM
"$AGVCAL" simulate "$TMP/sim3d.yaml" "$TMP/clouds.log" --trajectory demo --quiet
expect_status 0 "ground --write-robot" \
  "$AGVCAL" ground "$TMP/cal.yaml" "$TMP/clouds.log" --no-grid --out "$TMP/ground.json" --write-robot "$TMP/cal3d.yaml"
grep -qE "pitch +0\.03[0-9]* ± [0-9.]+ rad \(2\.0[0-9]* ± [0-9.]+ deg\)" "$TMP/stdout" \
  && pass "ground prints radians with degrees beside" || fail "ground's pitch line: $(cat "$TMP/stdout")"
check_written "$TMP/cal.yaml" "$TMP/cal3d.yaml" "$TMP/ground.json" lidar3d \
  && pass "ground's robot file: comments kept, lidar3d rounded to its sigma" || fail "ground's robot file: $(cat "$TMP/cal3d.yaml")"
grep -qF "params: {drive_radius:" "$TMP/cal3d.yaml" && grep -qF "lidar3d: {z:" "$TMP/cal3d.yaml" \
  && pass "solve's sigmas kept beside ground's" || fail "std: merged: $(cat "$TMP/cal3d.yaml")"
expect_status 0 "ground's robot file reads back" "$AGVCAL" ground "$TMP/cal3d.yaml" "$TMP/clouds.log" --no-grid --quiet
finish
