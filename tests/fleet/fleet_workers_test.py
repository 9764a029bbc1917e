"""The same rows whatever runs them: a subset of the fixture's fleet (the failing recording,
the step, an effect robot) on a LocalCluster of 2 workers, one of whose worker processes is
killed (SIGKILL) while it runs a task: Dask retries the task on a worker the nanny restarts,
both workers take tasks, and every row equals the one-worker reference (fleet_e2e). Two
workers undisturbed give the reference's rows in fleet_postgres and fleet_scheduler too."""
import os
import signal
import sqlite3
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fleetlib import (FIXTURE, FLEET_CMD, SUBSET, check, finish, fleet, hashes_of,  # noqa: E402
                      result_rows, same_rows, subset_fleet, tmpdir, wait_for)

import psutil  # noqa: E402  (python3-psutil, a dependency of python3-distributed)

ref = os.path.join(FIXTURE, "ref.sqlite")
tmp = tmpdir()
fy = subset_fleet(os.path.join(tmp, "fleet.yaml"))
want = result_rows(ref, hashes_of(ref, SUBSET))
n = len(want["recordings"])
check(n == 22, f"the reference has the subset's {n} recordings")

# A run on a LocalCluster of 2 workers, one of them killed while it runs agvcal.
dbk = os.path.join(tmp, "killed.sqlite")
proc = subprocess.Popen([FLEET_CMD, "run", fy, "--db", dbk, "--workers", "2"],
                        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def done_tasks():
    try:
        con = sqlite3.connect(dbk, timeout=1)
        try:
            return con.execute("SELECT count(*) FROM tasks").fetchone()[0]
        finally:
            con.close()
    except sqlite3.Error:
        return 0


def busy_worker():
    """A worker process of this run (a child of the agvcal-fleet process) that is running agvcal."""
    try:
        me = psutil.Process(proc.pid)
        for c in me.children():
            if any(os.path.basename(g.exe() if g.exe() else "") == "agvcal" for g in c.children()):
                return c
    except psutil.Error:
        pass
    return None


killed = None
if wait_for(lambda: done_tasks() >= 4, 300):
    victim = wait_for(busy_worker, 60, step=0.05)
    if victim:
        running = [g.cmdline()[-5:] for g in victim.children()]
        victim.send_signal(signal.SIGKILL)
        killed = (victim.pid, done_tasks(), running)
out, err = proc.communicate(timeout=600)
check(killed is not None, f"a worker was killed while it ran agvcal (pid, tasks done then, its command: {killed})")
check(proc.returncode == 0, "the run on 2 workers ends normally (exit 0) after losing one", err[-600:])
con = sqlite3.connect(dbk)
run = con.execute("SELECT status, submitted, done, failed, lost FROM runs").fetchone()
workers = {w for (w,) in con.execute("SELECT DISTINCT worker FROM tasks")}
con.close()
check(len(workers) >= 2, f"both workers did tasks ({sorted(workers)})")
check(run == ("finished", 22, 22, 1, 0), "every task done, none lost (the killed one was retried)", str(run))
diff = same_rows(want, result_rows(dbk))
check(not diff, "2 workers, one killed: every row equals the 1-worker run's", diff)
finish()
