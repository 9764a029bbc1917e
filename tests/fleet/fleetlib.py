"""Helpers of the fleet tests (tests/fleet/*_test.py), run by ctest with /usr/bin/python3
as `python3 TEST BUILD_DIR SOURCE_DIR`. A check prints PASS or FAIL; the test exits 1 if any
failed, 77 (ctest: skipped) when it calls skip()."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

BUILD = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else os.path.abspath("build")
SRC = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else os.path.abspath(".")
FLEET_CMD = os.path.join(SRC, "scripts", "agvcal-fleet")
AGVCAL = os.path.join(BUILD, "agvcal")
FIXTURE = os.path.join(BUILD, "tests", "fleet-fixture")  # made by fleet_e2e_test.py
sys.path.insert(0, os.path.join(SRC, "scripts"))
os.environ["AGVCAL_BIN"] = BUILD

# The test fleet: 7 robots x 7 recordings over 7 weeks and one truncated recording.
PLAN = "constant,constant@forklift,drift,step@forklift,effect,effect,effect"
# A subset that is run again on other clusters and databases and compared row by row:
# the robot with the failing recording, the step and an effect robot.
SUBSET = ["agv-001", "agv-004", "agv-005"]

_fails = 0
_passes = 0


def check(ok, what, detail=""):
    global _fails, _passes
    if ok:
        _passes += 1
        print(f"PASS {what}", flush=True)
    else:
        _fails += 1
        print(f"FAIL {what}" + (f": {detail}" if detail else ""), flush=True)
    return ok


def skip(why):
    print(f"SKIP {why}", flush=True)
    sys.exit(77)


def finish():
    print(f"checks: {_passes} passed, {_fails} failed", flush=True)
    sys.exit(1 if _fails else 0)


def fleet(*args, timeout=600, env=None, **kw):
    """Runs agvcal-fleet ARGS; returns the CompletedProcess (stdout, stderr as text)."""
    return subprocess.run([FLEET_CMD, *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env, **kw)


def tmpdir():
    d = tempfile.mkdtemp(prefix="agvcal-fleet-test-")
    import atexit
    atexit.register(shutil.rmtree, d, True)
    return d


def subset_fleet(path, robots=SUBSET):
    """A fleet.yaml with only ROBOTS of the fixture's fleet."""
    with open(path, "w") as f:
        f.write("robots:\n")
        for r in robots:
            f.write(f"  {r}: {{robot: {FIXTURE}/fleet/robots/{r}.yaml, "
                    f"recordings: {FIXTURE}/fleet/logs/{r}/*.log}}\n")
    return path


def result_rows(url, recording_hashes=None):
    from agvcal_fleet import db as dbmod
    db = dbmod.Database(url)
    try:
        return db.result_rows(recording_hashes)
    finally:
        db.close()


def hashes_of(url, robots):
    from agvcal_fleet import db as dbmod
    db = dbmod.Database(url)
    try:
        q = "SELECT sha256 FROM recordings WHERE robot_id IN (%s)" % ",".join("?" * len(robots))
        return [h for (h,) in db.query(q, robots)]
    finally:
        db.close()


def same_rows(a, b):
    """'' when the two {table: rows} are identical, else what differs first."""
    for t in a:
        if a[t] != b.get(t):
            ra, rb = a[t], b.get(t, [])
            if len(ra) != len(rb):
                return f"{t}: {len(ra)} rows against {len(rb)}"
            for x, y in zip(ra, rb):
                if x != y:
                    return f"{t}: {x} against {y}"
    return ""


def truth():
    with open(os.path.join(FIXTURE, "fleet", "truth.json")) as f:
        return json.load(f)


def wait_for(cond, timeout, step=0.2):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        v = cond()
        if v:
            return v
        time.sleep(step)
    return None
