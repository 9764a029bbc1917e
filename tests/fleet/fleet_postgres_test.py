"""PostgreSQL: a server the test starts itself (initdb in a temporary folder, a Unix socket
there, no TCP), the schema created and migrated by the tool, the fixture's subset run into
it on 2 workers: every row equals the SQLite reference's, a rerun does nothing, and the
analysis on PostgreSQL gives the same decisions as on SQLite. Skipped (exit 77) when the
postgresql package or python3-psycopg2 is missing."""
import glob
import json
import os
import pwd
import shutil
import sqlite3
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fleetlib import (FIXTURE, SUBSET, check, finish, fleet, hashes_of, result_rows,  # noqa: E402
                      same_rows, skip, subset_fleet, tmpdir)

bins = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))
if not bins:
    skip("PostgreSQL is not installed (Debian package postgresql; CI installs it)")
try:
    import psycopg2  # noqa: F401
except ImportError:
    skip("python3-psycopg2 is not installed")
bindir = os.path.dirname(bins[-1])

tmp = tmpdir()
os.chmod(tmp, 0o755)
pgdir = os.path.join(tmp, "pg")
os.makedirs(pgdir)
as_user = []
if os.getuid() == 0:  # PostgreSQL refuses to run as root
    as_user = ["runuser", "-u", "nobody", "--"]
    nobody = pwd.getpwnam("nobody")
    os.chown(pgdir, nobody.pw_uid, nobody.pw_gid)
data, sock = os.path.join(pgdir, "data"), pgdir
p = subprocess.run(as_user + [f"{bindir}/initdb", "-D", data, "-U", "fleet", "--auth=trust", "-E", "UTF8"],
                   capture_output=True, text=True)
check(p.returncode == 0, "initdb in a temporary folder", p.stderr[-400:])
port = 5400 + os.getpid() % 500
server = subprocess.Popen(as_user + [f"{bindir}/postgres", "-D", data, "-k", sock, "-p", str(port),
                                     "-c", "listen_addresses=", "-c", "fsync=off"],
                          stdout=subprocess.DEVNULL, stderr=open(os.path.join(tmp, "pg.log"), "w"))
try:
    url_admin = f"postgresql://fleet@/postgres?host={sock}&port={port}"
    conn = None
    for _ in range(100):
        try:
            conn = psycopg2.connect(url_admin)
            break
        except psycopg2.OperationalError:
            time.sleep(0.2)
    if not check(conn is not None, "the server accepts connections", open(os.path.join(tmp, "pg.log")).read()[-400:]):
        finish()
    conn.autocommit = True
    conn.cursor().execute("CREATE DATABASE fleet")
    conn.close()
    url = f"postgresql://fleet@/fleet?host={sock}&port={port}"

    p = fleet("migrate", "--db", url)
    check(p.returncode == 0 and "applied 1" in p.stdout, "migrate creates the schema", p.stdout + p.stderr)
    p = fleet("migrate", "--db", url)
    check(p.returncode == 0 and "up to date" in p.stdout, "migrate again: up to date", p.stdout + p.stderr)

    ref = os.path.join(FIXTURE, "ref.sqlite")
    fy = subset_fleet(os.path.join(tmp, "fleet.yaml"))
    p = fleet("run", fy, "--db", url, "--workers", 2)
    check(p.returncode == 0, "run into PostgreSQL on 2 workers", p.stderr[-500:])
    want = result_rows(ref, hashes_of(ref, SUBSET))
    diff = same_rows(want, result_rows(url))
    check(not diff, f"PostgreSQL rows equal SQLite's ({sum(map(len, want.values()))} rows)", diff)
    p = fleet("run", fy, "--db", url, "--workers", 2)
    check(p.returncode == 0 and "22 done before, 0 to do" in p.stderr, "a rerun skips every recording", p.stderr[-300:])

    # the same decisions from both databases: the reference cut down to the subset
    sub = os.path.join(tmp, "subset.sqlite")
    shutil.copy(ref, sub)
    con = sqlite3.connect(sub)
    keep = ",".join(f"'{r}'" for r in SUBSET)
    gone = f"(SELECT sha256 FROM recordings WHERE robot_id NOT IN ({keep}))"
    for t in ("calibration_params", "diagnosis_effects", "calibrations", "diagnoses"):
        con.execute(f"DELETE FROM {t} WHERE recording_sha256 IN {gone}")
    con.execute("DELETE FROM tasks")
    con.execute(f"DELETE FROM recordings WHERE robot_id NOT IN ({keep})")
    con.execute(f"DELETE FROM robots WHERE robot_id NOT IN ({keep})")
    con.commit()
    con.close()
    js = {}
    for name, u in (("sqlite", sub), ("postgresql", url)):
        p = fleet("analyze", "--db", u, "--json", os.path.join(tmp, name + ".json"), "--quiet")
        check(p.returncode == 0, f"analyze on {name}", p.stderr[-300:])
        js[name] = json.load(open(os.path.join(tmp, name + ".json")))["findings"]
    check(js["sqlite"] == js["postgresql"] and any(f["kind"] == "step" for f in js["postgresql"]),
          f"the same {len(js['postgresql'])} findings from PostgreSQL and SQLite (the step among them)",
          json.dumps(js)[:600])
    p = fleet("report", "--db", url, "--out", os.path.join(tmp, "report"))
    check(p.returncode == 0 and os.path.isfile(os.path.join(tmp, "report", "robots", "agv-004.html")),
          "report from PostgreSQL", p.stderr[-300:])
    p = fleet("run", fy, "--db", f"postgresql://fleet@/nosuchdb?host={sock}&port={port}")
    check(p.returncode == 2 and "cannot connect" in p.stderr and p.stderr.count("\n") == 1,
          "a database that does not exist: exit 2, one line", p.stderr)
finally:
    server.terminate()
    server.wait(timeout=60)
finish()
