"""agvcal-fleet end to end on a small simulated fleet (also the fixture of the other fleet
tests: BUILD/tests/fleet-fixture/{fleet/, ref.sqlite}).

7 robots x 7 recordings (a constant differential and forklift, a drifting one, a forklift
with a step, three that get a lidar latency on the same day) and a truncated recording.
Run on a LocalCluster with one worker into SQLite; checks the rows (the failing recording
has its exit status and message), that a rerun does nothing and changes no row, that the
analysis (which reads the database only) finds the step at its recording, flags the drift,
flags no constant robot and finds the fleet-wide latency, and that the report renders in
headless chromium without layout problems."""
import json
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fleetlib import (FIXTURE, PLAN, SRC, check, finish, fleet, result_rows, same_rows, tmpdir,  # noqa: E402
                      truth)

shutil.rmtree(FIXTURE, ignore_errors=True)
os.makedirs(FIXTURE)
fl = os.path.join(FIXTURE, "fleet")
ref = os.path.join(FIXTURE, "ref.sqlite")
p = fleet("synth", fl, "--plan", PLAN, "--recordings", 7, "--days", 49, "--broken", 1, "--seed", 7,
          "--jobs", 2, "--quiet")
if not check(p.returncode == 0, "synth makes the test fleet", p.stderr[-500:]):
    finish()
T = truth()

p = fleet("run", os.path.join(fl, "fleet.yaml"), "--db", ref, "--workers", 1)
check(p.returncode == 0, "run on a LocalCluster with 1 worker (exit 0)", p.stderr[-800:])
check(re.search(r"50 of 50 done, 1 failed, 0 left", p.stderr) is not None,
      "progress says done / failed / left", p.stderr[-400:])

import sqlite3  # noqa: E402
con = sqlite3.connect(ref)
n_rec = con.execute("SELECT count(*) FROM recordings").fetchone()[0]
check(n_rec == 50, "50 recordings in the database", str(n_rec))
rows = con.execute("SELECT r.path, r.info_exit, c.exit_status, c.message, d.exit_status, d.message "
                   "FROM recordings r JOIN calibrations c ON c.recording_sha256 = r.sha256 "
                   "JOIN diagnoses d ON d.recording_sha256 = r.sha256 WHERE r.path LIKE '%broken%'").fetchall()
# A cut-short recording reads up to its last whole event (info: exit 0, the skip named); too
# little is left to calibrate, and the calibration's message names the cut as the cause.
check(len(rows) == 1 and rows[0][1] == 0 and rows[0][2] == 2 and rows[0][4] in (2, 3)
      and "broken00.log" in rows[0][3] and "cut short" in rows[0][3],
      "the truncated recording has a row with exit status 2 and a message naming the cut", str(rows))
ok = con.execute("SELECT count(*) FROM calibrations WHERE exit_status = 0 AND heldout_exit = 0 "
                 "AND heldout_verdict IS NOT NULL").fetchone()[0]
check(ok == 49, "49 calibrations with the held-out verdict", str(ok))
npar = con.execute("SELECT count(*) FROM calibration_params WHERE std > 0").fetchone()[0]
check(npar == 49 * 6, "every parameter with its sigma (6 per calibration)", str(npar))
starts = con.execute("SELECT path, start_utime, duration_s, distance_m FROM recordings WHERE info_exit = 0 "
                     "AND path NOT LIKE '%broken%'").fetchall()
want = {os.path.join(fl, rc["file"]): rc["start_utime"] for r in T["robots"].values() for rc in r["recordings"]}
check(all(want[pth] <= s < want[pth] + 1000000 and 20 < dur < 40 and dist > 1 for pth, s, dur, dist in starts),
      "start time from the recording's own messages, duration and distance", str(starts[:2]))
fx = con.execute("SELECT count(DISTINCT recording_sha256) FROM diagnosis_effects WHERE effect = 'time_offset'").fetchone()[0]
check(fx >= 6, "the diagnosis finds the latency in the affected recordings (effects with sizes)", str(fx))
con.close()
before = result_rows(ref)

p = fleet("run", os.path.join(fl, "fleet.yaml"), "--db", ref, "--workers", 1)
check(p.returncode == 0 and "50 done before, 0 to do" in p.stderr,
      "a rerun skips every recording (keyed by content hash)", p.stderr[-400:])
check(not same_rows(before, result_rows(ref)), "a rerun leaves every row as it was")

# Decisions, from the database alone.
out = tmpdir()
p = fleet("analyze", "--db", ref, "--json", os.path.join(out, "findings.json"))
check(p.returncode == 0, "analyze", p.stderr[-400:])
print(p.stdout)
F = json.load(open(os.path.join(out, "findings.json")))["findings"]
trend = [f for f in F if f["kind"] in ("drift", "step")]
path_index = {}
for rid, r in T["robots"].items():
    for j, rc in enumerate(r["recordings"]):
        path_index[os.path.join(fl, rc["file"])] = j
for rid, r in sorted(T["robots"].items()):
    mine = [f for f in trend if f["robot_id"] == rid]
    if r["scenario"] in ("constant", "effect"):
        check(not mine, f"{rid} ({r['scenario']}, constant parameters): no drift or step flagged",
              str([f["why"] for f in mine]))
    elif r["scenario"] == "drift":
        changed = set(r["changed"])
        check(any(f["subject"] in changed for f in mine),
              f"{rid}: the drift of {', '.join(changed)} ({r['kind']}) is flagged", str([f["why"] for f in mine]))
    elif r["scenario"] == "step":
        steps = [f for f in mine if f["kind"] == "step" and f["subject"] in r["changed"]]
        got = [path_index[f["detail"]["first_path"]] for f in steps]
        check(steps and all(abs(g - r["change_recording"]) <= 1 for g in got),
              f"{rid}: the step ({r['kind']}) is found at recording {got}, injected at {r['change_recording']}",
              str([f["why"] for f in mine]))
fw = [f for f in F if f["kind"] == "fleet_effect"]
eff = sorted(rid for rid, r in T["robots"].items() if r["scenario"] == "effect")
check(len(fw) == 1 and fw[0]["subject"] == "time_offset" and fw[0]["detail"]["robots"] == eff,
      f"the fleet-wide latency is found in {eff}", str([f["why"] for f in fw]))
if fw:
    first = {rid: path_index[pth] for rid, pth in fw[0]["detail"]["first_recordings"].items()}
    check(all(abs(first[rid] - T["robots"][rid]["effect_recording"]) <= 1 for rid in eff),
          "each robot's onset within one recording of the firmware day", str(first))
check(any(f["kind"] == "failed" and f["robot_id"] == "agv-001" for f in F),
      "the failing recording is reported (its robot needs attention)")

# The report, rendered by a real browser.
rep = os.path.join(out, "report")
p = fleet("report", "--db", ref, "--out", rep)
check(p.returncode == 0 and os.path.isfile(os.path.join(rep, "index.html")), "report writes index.html", p.stderr[-300:])
pages = sorted(os.listdir(os.path.join(rep, "robots")))
check(all(f"agv-00{i}.html" in pages for i in range(1, 8)), "one page per robot")
svgs = [os.path.join(rep, f) for f in os.listdir(rep) if f.endswith(".svg")] + \
       [os.path.join(rep, "robots", f) for f in pages if f.endswith(".svg")]
bad = []
for s in svgs:
    try:
        ET.parse(s)
    except ET.ParseError as e:
        bad.append(f"{s}: {e}")
check(len(svgs) > 40 and not bad, f"{len(svgs)} SVG plots, all well-formed XML", str(bad[:3]))
index = open(os.path.join(rep, "index.html")).read()
for rid in ["agv-003", "agv-004", "agv-005"]:
    check(f'href="robots/{rid}.html"' in index, f"the index links {rid} (needs attention)")
# Every page as the C++ reports' (tests/tools/browser_check.py): a verdict sentence under the title,
# what produced it, no internal notes.
sys.path.insert(0, os.path.join(SRC, "tests", "tools"))
import browser_check  # noqa: E402
problems = []
for pg in ["index.html"] + [os.path.join("robots", f) for f in pages if f.endswith(".html")]:
    problems += browser_check.content_problems(pg, open(os.path.join(rep, pg), encoding="utf-8").read(),
                                               browser_check.FLEET_PROVENANCE_KEYS)
check(not problems, "every page opens with a verdict sentence and what produced it", str(problems[:5]))

chromium = shutil.which("chromium") or shutil.which("chromium-browser")
if not chromium:
    print("SKIP browser checks: chromium is not installed (Debian package chromium; CI installs it)")
else:
    def browse(url, *extra):
        prof = tmpdir()
        cmd = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               "--disable-dev-shm-usage", f"--user-data-dir={prof}", "--window-size=1024,800",
               "--virtual-time-budget=10000", *extra, url]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=120)

    for pg in ["index.html", "robots/agv-004.html", "robots/agv-005.html"]:
        r = browse("file://" + os.path.join(rep, pg) + "#check", "--dump-dom")
        m = re.search(r'<pre id="layout-check">(.*?)</pre>', r.stdout, re.S)
        res = json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<")
                         .replace("&gt;", ">")) if m else None
        check(res is not None and res["images"] >= 3 and not res["problems"],
              f"chromium renders {pg}: {res['images'] if res else '?'} images loaded, no overflow",
              str(res["problems"][:5]) if res else r.stderr[-300:])
    # the check itself sees a problem when there is one: a too-wide block and a missing image
    broken = os.path.join(rep, "broken.html")
    with open(broken, "w") as f:
        f.write(index.replace("<h1>", '<div style="width:1600px">wide</div><img src="missing.svg" '
                              'width="640" height="200"><h1>', 1))
    r = browse("file://" + broken + "#check", "--dump-dom")
    m = re.search(r'<pre id="layout-check">(.*?)</pre>', r.stdout, re.S)
    probs = json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&"))["problems"] if m else []
    check(any("wider than the window" in x for x in probs) and any("missing.svg" in x for x in probs),
          "the layout check reports a page wider than the window and a missing image", str(probs))
    png = os.path.join(out, "index.png")
    browse("file://" + os.path.join(rep, "index.html"), f"--screenshot={png}", "--hide-scrollbars")

    def png_pixels(path):
        data = open(path, "rb").read()
        pos, idat = 8, b""
        while pos < len(data):
            n = int.from_bytes(data[pos:pos + 4], "big")
            if data[pos + 4:pos + 8] == b"IDAT":
                idat += data[pos + 8:pos + 8 + n]
            pos += 12 + n
        return zlib.decompress(idat)
    px = png_pixels(png) if os.path.isfile(png) else b""
    check(len(px) > 1024 * 800 and len(set(px[::7])) > 20,
          "the screenshot of the index is not blank", f"{len(px)} bytes, {len(set(px[::7]))} values")
finish()
