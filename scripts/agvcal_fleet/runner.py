"""`agvcal-fleet run`: every recording of the fleet not yet done, as a task on Dask.

The client (this process) hashes the recordings, skips those whose results are in the
database, submits the rest (one task per recording, keyed by its content hash), and writes
each result to the database as it arrives, one transaction per recording: an interrupted
night loses nothing that finished, and the next run continues where it stopped. Tasks run
on an in-process LocalCluster, or on a running scheduler (`--scheduler tcp://HOST:8786`).
A worker that dies has its task retried on another (Dask: up to 3 deaths per task, then the
task is recorded as lost and tried again by the next run).
"""
import datetime
import logging
import os
import socket
import sys
import time
import uuid

import yaml

from . import db as dbmod
from . import tasks
from .errors import UsageError


def utc_now():
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def recording_hashes(db, paths, progress=None):
    """{path: (sha256, size)}, from the files table where size and mtime are unchanged."""
    cached = {p: (s, m, h) for p, s, m, h in db.query("SELECT path, size_bytes, mtime_ns, sha256 FROM files")}
    out = {}
    for i, p in enumerate(paths):
        try:
            st = os.stat(p)
        except OSError as e:
            raise UsageError(f"{p}: cannot read ({e.strerror})")
        c = cached.get(p)
        if c and c[0] == st.st_size and c[1] == st.st_mtime_ns:
            out[p] = (c[2], st.st_size)
            continue
        try:
            h = tasks.sha256_file(p)
        except OSError as e:
            raise UsageError(f"{p}: cannot read ({e.strerror})")
        db.upsert("files", ["path"], {"path": p, "size_bytes": st.st_size,
                                      "mtime_ns": st.st_mtime_ns, "sha256": h})
        out[p] = (h, st.st_size)
        if progress and (i + 1) % 200 == 0:
            progress(f"hashed {i + 1} of {len(paths)} recordings")
    return out


def robot_drive(robot_file):
    """The robot file's drive type, or None when it does not read (agvcal will say why)."""
    try:
        with open(robot_file, encoding="utf-8") as f:
            doc = yaml.safe_load(f)
        return doc.get("drive") if isinstance(doc, dict) else None
    except (OSError, yaml.YAMLError):
        return None


def write_result(db, run_id, robot_id, path, size, res, lost_message=None):
    """One recording's rows (recording, calibration, parameters, diagnosis, effects, task),
    in one transaction. RES is tasks.process_recording's dict; LOST_MESSAGE instead when the
    task never returned (its rows then have no exit status and are redone next run)."""
    sha, robot_sha = res["sha256"], res["robot_sha256"]
    step = (lambda name: res.get(name) or {"exit": None, "message": lost_message, "json": None})
    info, solve, ho, diag = step("info"), step("solve"), step("heldout"), step("diagnose")
    ij, sj, hj, dj = info["json"] or {}, solve["json"] or {}, ho["json"] or {}, diag["json"] or {}
    start, end = ij.get("start_utime"), ij.get("end_utime")
    version = res.get("task_version", tasks.TASK_VERSION)
    with db.transaction():
        db.upsert("recordings", ["sha256"], {
            "sha256": sha, "robot_id": robot_id, "path": path, "size_bytes": size,
            "info_exit": info["exit"], "info_message": info["message"],
            "start_utime": start, "end_utime": end,
            "duration_s": (end - start) * 1e-6 if start is not None and end is not None else None,
            "distance_m": dj.get("distance_m"),
            "channels": dbmod.dumps(ij["channels"]) if "channels" in ij else None})
        rms = sj.get("rms") or [None] * 3
        db.upsert("calibrations", ["recording_sha256"], {
            "recording_sha256": sha, "robot_sha256": robot_sha, "task_version": version,
            "exit_status": solve["exit"], "message": solve["message"], "drive": sj.get("drive"),
            "intervals": sj.get("intervals"), "outliers": sj.get("outliers"),
            "rms_x": rms[0], "rms_y": rms[1], "rms_yaw": rms[2],
            "condition_number": sj.get("condition"),
            "weak": dbmod.dumps(sj["weak"]) if "weak" in sj else None,
            "heldout_exit": ho["exit"], "heldout_message": ho["message"],
            "heldout_verdict": hj.get("verdict"),
            "heldout_nominal_error_per_m": hj.get("nominal_error_per_m"),
            "heldout_calibrated_error_per_m": hj.get("calibrated_error_per_m"),
            "heldout_windows": hj.get("windows"),
            "heldout_calibrated_better": hj.get("calibrated_better"),
            "heldout_sign_p": hj.get("sign_test_p"), "heldout_halves_p": hj.get("halves_p"),
            "heldout_halves_largest": hj.get("halves_largest"),
            "heldout_outside_fit": hj.get("outside_fit")})
        db.execute("DELETE FROM calibration_params WHERE recording_sha256 = ?", (sha,))
        for p in sj.get("params", []):
            db.insert("calibration_params", {"recording_sha256": sha, "name": p["name"],
                                             "value": p["value"], "std": p["std"],
                                             "nominal": p["nominal"]})
        db.upsert("diagnoses", ["recording_sha256"], {
            "recording_sha256": sha, "robot_sha256": robot_sha, "task_version": version,
            "exit_status": diag["exit"], "message": diag["message"], "verdict": dj.get("verdict"),
            "unexplained": dj.get("unexplained"), "chi2_before": dj.get("chi2_before"),
            "chi2_after": dj.get("chi2_after")})
        db.execute("DELETE FROM diagnosis_effects WHERE recording_sha256 = ?", (sha,))
        for e in dj.get("effects", []):
            db.insert("diagnosis_effects", {
                "recording_sha256": sha, "effect": e["name"], "wheel": e["wheel"],
                "param": e["param"], "value": e["value"], "std": e["std"], "layer": e["layer"],
                "p_value": e["p_value"], "delta_bic": e["delta_bic"],
                "heldout_rms_before": e["heldout_rms_before"],
                "heldout_rms_after": e["heldout_rms_after"], "regime": e["regime"]})
        status = task_status(res) if lost_message is None else "lost"
        db.upsert("tasks", ["run_id", "recording_sha256"], {
            "run_id": run_id, "recording_sha256": sha, "status": status,
            "worker": res.get("worker"), "elapsed_s": res.get("elapsed_s")})
    return status


def task_status(res):
    """ok: every step exit 0; failed: a step's exit status is not 0 (the recording's answer)."""
    return "ok" if all((res.get(s) or {}).get("exit") == 0
                       for s in ("info", "solve", "heldout", "diagnose")) else "failed"


class Progress:
    """Tasks done / failed / left and the time left, on one terminal line (or a line every
    30 s when stderr is not a terminal)."""

    def __init__(self, total, quiet=False, stream=sys.stderr):
        self.total, self.quiet, self.stream = total, quiet, stream
        self.tty = stream.isatty()
        self.t0 = time.monotonic()
        self.last = 0.0
        self.shown = None
        self.done = self.failed = self.lost = 0

    def update(self, status, final=False):
        if status:
            self.done += 1
            self.failed += status == "failed"
            self.lost += status == "lost"
        now = time.monotonic()
        if self.quiet or (not final and not self.tty and now - self.last < 30 and self.done < self.total):
            return
        if final and not self.tty and self.shown == self.done:
            return
        self.last, self.shown = now, self.done
        left = self.total - self.done
        el = now - self.t0
        rate = self.done / el * 60 if el > 0 else 0.0
        eta = f"about {_duration(left / rate * 60)} left" if rate > 0 and left else ""
        line = (f"agvcal-fleet: {self.done} of {self.total} done, {self.failed} failed"
                + (f", {self.lost} lost" if self.lost else "") + f", {left} left; "
                f"{rate:.1f} recordings/min; {eta or _duration(el) + ' elapsed'}")
        if self.tty:
            self.stream.write("\r\033[K" + line + ("\n" if final else ""))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


def _duration(s):
    s = int(round(s))
    return f"{s // 3600} h {s % 3600 // 60:02d} min" if s >= 3600 else (
        f"{s // 60} min {s % 60:02d} s" if s >= 60 else f"{s} s")


def find_agvcal(option):
    """The agvcal binary: --agvcal, else $AGVCAL_BIN (a file, or the build folder the tests
    export), else build/agvcal next to this script's checkout, else `agvcal` on PATH."""
    import shutil
    cands = [option] if option else []
    env = os.environ.get("AGVCAL_BIN")
    if not option and env:
        cands.append(os.path.join(env, "agvcal") if os.path.isdir(env) else env)
    if not cands:
        here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        cands += [os.path.join(here, "build", "agvcal"), shutil.which("agvcal") or ""]
    for c in cands:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return os.path.abspath(c)
    raise UsageError(f"agvcal binary not found (tried {', '.join(c for c in cands if c) or 'PATH'}); "
                     "build it or give --agvcal PATH")


def start_client(scheduler, workers, threads, connect_timeout=30):
    """A Dask client: on SCHEDULER, or on an in-process LocalCluster of WORKERS processes."""
    import dask
    from distributed import Client, LocalCluster
    dask.config.set({"distributed.scheduler.allowed-failures": 3,
                     "distributed.admin.tick.limit": "1h"})  # no warnings under heavy load
    if scheduler:
        try:
            client = Client(scheduler, timeout=connect_timeout)
        except Exception as e:  # OSError, TimeoutError, ValueError (a malformed address)
            raise UsageError(f"--scheduler {scheduler}: cannot connect ({str(e).splitlines()[0] if str(e) else type(e).__name__})")
        return client, None
    cluster = LocalCluster(n_workers=workers, threads_per_worker=threads, processes=True,
                           dashboard_address="127.0.0.1:0", silence_logs=logging.CRITICAL)
    return Client(cluster), cluster


def run(args):
    from . import fleetfile
    robots = fleetfile.load(args.fleet)
    agvcal = find_agvcal(args.agvcal)
    db = dbmod.Database(args.db)
    db.migrate()
    client = cluster = None
    if args.scheduler:  # fail before doing anything when it cannot be reached
        client, cluster = start_client(args.scheduler, 0, 0, args.connect_timeout)
    say = (lambda m: None) if args.quiet else (lambda m: print("agvcal-fleet: " + m, file=sys.stderr, flush=True))

    run_id = utc_now().replace(":", "").replace("-", "") + "-" + uuid.uuid4().hex[:8]
    t0 = time.monotonic()
    todo, owner, n_total = [], {}, 0
    for r in robots:
        if not r.recordings:
            say(f"{r.robot_id}: no recordings match")
        robot_sha = tasks.sha256_file(r.robot_file)
        db.upsert("robots", ["robot_id"], {"robot_id": r.robot_id, "drive": robot_drive(r.robot_file),
                                           "robot_file": r.robot_file, "robot_sha256": robot_sha})
        with db.transaction():
            hashes = recording_hashes(db, r.recordings, say)
        for path in r.recordings:
            sha, size = hashes[path]
            if sha in owner:
                say(f"{path}: the same content as {owner[sha][1]} ({owner[sha][0]}); kept once")
                continue
            owner[sha] = (r.robot_id, path)
            n_total += 1
            todo.append({"robot_id": r.robot_id, "path": path, "size": size, "sha256": sha,
                         "robot_file": r.robot_file, "robot_sha256": robot_sha})
    done = db.done_keys(tasks.TASK_VERSION)
    pending = [t for t in todo if done.get(t["sha256"]) != t["robot_sha256"]]
    skipped = n_total - len(pending)
    where = args.scheduler or f"LocalCluster, {args.workers} worker{'s' * (args.workers != 1)}"
    db.insert("runs", {"run_id": run_id, "started_utc": utc_now(), "status": "running",
                       "host": socket.gethostname(), "scheduler": args.scheduler or "local",
                       "workers": None if args.scheduler else args.workers,
                       "fleet": os.path.abspath(args.fleet), "agvcal": agvcal,
                       "recordings": n_total, "skipped": skipped, "submitted": len(pending),
                       "done": 0, "failed": 0, "lost": 0})
    say(f"run {run_id}: {len(robots)} robots, {n_total} recordings, {skipped} done before, "
        f"{len(pending)} to do on {where}")
    progress = Progress(len(pending), quiet=args.quiet)
    status = "finished"
    try:
        if pending:
            import cloudpickle
            from distributed import as_completed
            cloudpickle.register_pickle_by_value(tasks)  # workers need not import this package
            if client is None:
                client, cluster = start_client(None, args.workers, args.threads)
            if args.scheduler:
                n = len(client.scheduler_info().get("workers", {}))
                say(f"{args.scheduler}: {n} worker{'s' * (n != 1)}")
                db.execute("UPDATE runs SET workers = ? WHERE run_id = ?", (n, run_id))
            futures = {}
            for t in pending:
                spec = {"path": t["path"], "sha256": t["sha256"], "robot_file": t["robot_file"],
                        "robot_sha256": t["robot_sha256"], "agvcal": agvcal,
                        "timeout_s": args.task_timeout, "nice": args.nice}
                key = f"agvcal-{t['sha256'][:24]}-{t['robot_sha256'][:8]}-v{tasks.TASK_VERSION}"
                futures[client.submit(tasks.process_recording, spec, key=key, pure=False)] = t
            progress.update(None)
            for fut in as_completed(list(futures)):
                t = futures[fut]
                if fut.status == "finished":
                    st = write_result(db, run_id, t["robot_id"], t["path"], t["size"], fut.result())
                else:
                    exc = fut.exception()
                    msg = f"task lost: {type(exc).__name__}: {str(exc)[:300]}"
                    st = write_result(db, run_id, t["robot_id"], t["path"], t["size"],
                                      {"sha256": t["sha256"], "robot_sha256": t["robot_sha256"]},
                                      lost_message=msg)
                progress.update(st)
                fut.release()
    except KeyboardInterrupt:
        status = "interrupted"
    except BaseException:
        status = "failed"
        raise
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
        db.execute("UPDATE runs SET finished_utc = ?, status = ?, done = ?, failed = ?, lost = ?, "
                   "elapsed_s = ? WHERE run_id = ?",
                   (utc_now(), status, progress.done, progress.failed, progress.lost,
                    time.monotonic() - t0, run_id))
    if pending:
        progress.update(None, final=True)
    say(f"run {run_id} {status}: {progress.done} of {len(pending)} recordings processed "
        f"({progress.failed} failed{f', {progress.lost} lost' if progress.lost else ''}), "
        f"{skipped} skipped as done; database {_show_db(args.db)}")
    db.close()
    if status == "interrupted":
        return 130
    return 0


def _show_db(url):
    return dbmod._redact(url)
