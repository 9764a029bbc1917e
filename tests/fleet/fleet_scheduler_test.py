"""`agvcal-fleet run --scheduler`: a Dask cluster started the way docs/fleet.md says
(`dask scheduler`, two `dask worker` processes), in a private network namespace so that
nothing is heard outside (the workers join over TCP on its loopback). The subset of the
fixture's fleet run there gives the rows of the one-worker reference; both workers take
tasks; an address where no scheduler listens is exit 2 with one line."""
import os
import shutil
import sqlite3
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fleetlib import (BUILD, FIXTURE, SRC, SUBSET, check, finish, fleet, hashes_of,  # noqa: E402
                      result_rows, same_rows, skip, subset_fleet, tmpdir)

if os.environ.get("AGVCAL_FLEET_IN_NETNS") != "1":
    flags = ["-n"] if os.getuid() == 0 else ["-r", "-n"]
    env = dict(os.environ, AGVCAL_FLEET_IN_NETNS="1")
    p = subprocess.run(["unshare", *flags, "/usr/bin/python3", os.path.abspath(__file__), BUILD, SRC], env=env)
    if p.returncode == 1 and not os.path.exists("/proc/self/ns/net"):
        skip("no network namespaces here")
    sys.exit(p.returncode)

subprocess.run(["ip", "link", "set", "lo", "up"], check=True)
dask = shutil.which("dask")
if not dask:
    skip("the dask command is not installed (Debian package python3-dask)")
tmp = tmpdir()
port = 8786
log = open(os.path.join(tmp, "cluster.log"), "w")
procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                           "--no-dashboard"], stdout=log, stderr=log, cwd=tmp)]
time.sleep(2)
addr = f"tcp://127.0.0.1:{port}"
for name in ("w1", "w2"):
    procs.append(subprocess.Popen([dask, "worker", addr, "--nthreads", "1", "--nworkers", "1",
                                   "--no-dashboard", "--name", name, "--local-directory", tmp],
                                  stdout=log, stderr=log, cwd=tmp))
try:
    from distributed import Client
    c = Client(addr, timeout=60)
    t0 = time.monotonic()
    while len(c.scheduler_info()["workers"]) < 2 and time.monotonic() - t0 < 120:
        time.sleep(0.5)
    n = len(c.scheduler_info()["workers"])
    c.close()
    if not check(n == 2, f"dask scheduler with 2 dask workers over TCP ({n})",
                 open(os.path.join(tmp, "cluster.log")).read()[-600:]):
        finish()
    ref = os.path.join(FIXTURE, "ref.sqlite")
    fy = subset_fleet(os.path.join(tmp, "fleet.yaml"))
    db = os.path.join(tmp, "tcp.sqlite")
    p = fleet("run", fy, "--db", db, "--scheduler", addr)
    check(p.returncode == 0 and f"{addr}: 2 workers" in p.stderr, "run --scheduler", p.stderr[-500:])
    diff = same_rows(result_rows(ref, hashes_of(ref, SUBSET)), result_rows(db))
    check(not diff, "every row equals the 1-worker LocalCluster run's", diff)
    con = sqlite3.connect(db)
    workers = {w for (w,) in con.execute("SELECT DISTINCT worker FROM tasks")}
    run = con.execute("SELECT scheduler, workers, submitted, done, lost FROM runs").fetchone()
    con.close()
    check(len(workers) == 2, f"both workers took tasks ({sorted(workers)})")
    check(run == (addr, 2, 22, 22, 0), "the run is recorded with its scheduler and workers", str(run))
    p = fleet("run", fy, "--db", os.path.join(tmp, "x.sqlite"), "--scheduler", "tcp://127.0.0.1:1",
              "--connect-timeout", "3")
    check(p.returncode == 2 and "cannot connect" in p.stderr and p.stderr.strip().count("\n") == 0,
          "no scheduler at the address: exit 2, one line", p.stderr)
finally:
    for pr in reversed(procs):
        pr.terminate()
    for pr in procs:
        try:
            pr.wait(timeout=30)
        except subprocess.TimeoutExpired:
            pr.kill()
finish()
