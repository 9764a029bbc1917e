"""The unit of work: one recording through `agvcal info`, `solve`, `solve --fit-fraction`
and `diagnose`, on whichever Dask worker runs it.

Self-contained (standard library only): the client ships this module to the workers by
value, so a worker needs Python with Dask and the agvcal binary on shared storage, not this
package. The result is a plain dict (JSON-able), written to the database by the client.
A recording that fails gives a result too, with the failing command's exit status and its
message; only the death of the worker itself (Dask retries the task elsewhere) or a bug
here leaves the task without a result.
"""
import ctypes
import hashlib
import json
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time

# A task's version: part of what "done" means (results of an older task are redone).
TASK_VERSION = 1


def sha256_file(path, bufsize=1 << 20):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while True:
            b = f.read(bufsize)
            if not b:
                break
            h.update(b)
    return h.hexdigest()


def _die_with_parent():
    """In the agvcal child: be killed when the worker that started it dies (Linux)."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def _run(cmd, timeout_s, nice, stdout_path=None):
    """(exit status, last line of stderr) of CMD; a timeout gives status None."""
    def pre():
        _die_with_parent()
        if nice:
            os.nice(nice)
    stdout = open(stdout_path, "w") if stdout_path else subprocess.DEVNULL
    try:
        p = subprocess.run(cmd, stdout=stdout, stderr=subprocess.PIPE, text=True,
                           timeout=timeout_s, preexec_fn=pre)
    except subprocess.TimeoutExpired:
        return None, f"timed out after {timeout_s:g} s"
    except OSError as e:
        return 127, f"{cmd[0]}: cannot run ({e.strerror})"
    finally:
        if stdout_path:
            stdout.close()
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    return p.returncode, (lines[-1] if lines else "")[:2000]


def _remove_stale_folders():
    """Removes the scratch folders of tasks whose worker process died (killed mid-task)."""
    root = tempfile.gettempdir()
    for name in os.listdir(root):
        if name.startswith("agvcal-fleet-task-"):
            pid = name.split("-")[3]
            if pid.isdigit() and not os.path.exists(f"/proc/{pid}"):
                shutil.rmtree(os.path.join(root, name), ignore_errors=True)


def _read_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def process_recording(spec):
    """SPEC: {path, sha256, robot_file, robot_sha256, agvcal, timeout_s, nice}.

    Returns {sha256, robot_sha256, task_version, worker, elapsed_s, info: {exit, message,
    json}, solve: {...}, heldout: {...}, diagnose: {...}}: each step's exit status
    (None on a timeout), last stderr line and a summary of its output document
    (the SUMMARIES below: what the database keeps)."""
    t0 = time.monotonic()
    out = {"sha256": spec["sha256"], "robot_sha256": spec["robot_sha256"],
           "task_version": TASK_VERSION, "worker": socket.gethostname() + ":" + str(os.getpid())}
    agvcal, robot, log = spec["agvcal"], spec["robot_file"], spec["path"]
    timeout, nice = spec.get("timeout_s", 900), spec.get("nice", 0)
    _remove_stale_folders()
    tmp = tempfile.mkdtemp(prefix=f"agvcal-fleet-task-{os.getpid()}-")
    try:
        try:
            got = sha256_file(log)
        except OSError as e:
            got, err = None, f"{log}: cannot read ({e.strerror})"
        if got != spec["sha256"]:
            msg = err if got is None else f"{log}: changed since it was hashed (content differs)"
            for step in ("info", "solve", "heldout", "diagnose"):
                out[step] = {"exit": 2, "message": msg, "json": None}
            return out
        steps = {  # step: command (info prints its JSON on stdout, the others write {out})
            "info": [agvcal, "info", log, "--json"],
            "solve": [agvcal, "solve", robot, log, "--quiet", "--out", "{out}"],
            "heldout": [agvcal, "solve", robot, log, "--quiet", "--fit-fraction", "0.5",
                        "--out", "{out}"],
            "diagnose": [agvcal, "diagnose", robot, log, "--quiet", "--out", "{out}"],
        }
        for step, cmd in steps.items():
            o = os.path.join(tmp, step + ".json")
            status, msg = _run([a.replace("{out}", o) for a in cmd], timeout, nice,
                               stdout_path=o if step == "info" else None)
            doc = _read_json(o) if status == 0 else None
            if status == 0:
                try:
                    doc = SUMMARIES[step](doc)
                except (TypeError, KeyError, ValueError, AttributeError) as e:
                    status, msg, doc = 1, f"{step}: exit 0 but unreadable output ({e!r})", None
            out[step] = {"exit": status, "message": msg, "json": doc}
        return out
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        out["elapsed_s"] = time.monotonic() - t0


# What the database keeps of each step's output document (spec/cli.md, docs/calibration.md,
# docs/mismatch.md): small, so that results travel cheaply from the workers.
def _info(doc):
    ch = doc["channels"]
    return {"start_utime": min(c["first_utime"] for c in ch.values()),
            "end_utime": max(c["last_utime"] for c in ch.values()),
            "channels": {k: c["count"] for k, c in sorted(ch.items())}}


def _solve(doc):
    params = []
    for group, prefix in (("params", ""), ("lidar2d", "lidar2d."), ("pose", "pose.")):
        for k, v in sorted((doc.get(group) or {}).items()):
            if isinstance(v, dict) and "value" in v:
                params.append({"name": prefix + k, "value": v["value"], "std": v.get("std"),
                               "nominal": v.get("nominal")})
    res = doc.get("residual", {})
    obs = doc.get("observability", {})
    return {"drive": doc.get("drive"), "params": params,
            "intervals": res.get("intervals"), "outliers": res.get("outliers"),
            "rms": [res.get("rms_x"), res.get("rms_y"), res.get("rms_yaw")],
            "condition": obs.get("condition"), "weak": list(obs.get("weak", []))}


def _heldout(doc):
    h = doc.get("heldout")
    if not h:
        return {"verdict": "none"}
    p, halves = h.get("paired", {}), h.get("halves") or {}
    nom, cal = h.get("nominal", {}), h.get("calibrated", {})
    out = {"nominal_error_per_m": nom.get("error_per_metre"),
           "calibrated_error_per_m": cal.get("error_per_metre"),
           "windows": p.get("windows"), "calibrated_better": p.get("calibrated_better"),
           "sign_test_p": p.get("sign_test_p"), "halves_p": halves.get("p"),
           "halves_largest": halves.get("largest"),
           "halves_largest_sigmas": halves.get("largest_sigmas"),
           "outside_fit": (h.get("motion") or {}).get("heldout_outside_fit")}
    # The verdict in one word: the calibration predicts the held-out half better or worse
    # than the nominal model (sign test at 5 %), or the test cannot tell; "halves_disagree"
    # overrides when the two halves' own fits differ beyond their sigmas (p < 0.01).
    better, n, sp = out["calibrated_better"], out["windows"], out["sign_test_p"]
    if out["halves_p"] is not None and out["halves_p"] < 0.01:
        out["verdict"] = "halves_disagree"
    elif sp is not None and n and sp < 0.05:
        out["verdict"] = "better" if 2 * better > n else "worse"
    else:
        out["verdict"] = "not_significant"
    return out


def _diagnose(doc):
    effects = []
    for e in doc.get("effects", []):
        ev = e.get("evidence", {})
        for k, v in sorted(e.get("params", {}).items()):
            effects.append({"name": e["name"], "wheel": e.get("wheel") or "", "param": k,
                            "value": v["value"], "std": v.get("std"),
                            "layer": e.get("layer"), "p_value": ev.get("p_value"),
                            "delta_bic": ev.get("delta_bic"),
                            "heldout_rms_before": e.get("heldout_rms_before"),
                            "heldout_rms_after": e.get("heldout_rms_after"),
                            "regime": e.get("regime")})
    h = doc.get("heldout", {})
    route = [iv["motion"]["route_m"] for iv in doc.get("intervals", [])
             if "route_m" in iv.get("motion", {})]
    return {"verdict": doc["verdict"], "effects": effects,
            "unexplained": len(doc.get("unexplained", [])),
            "chi2_before": h.get("chi2_per_interval_before"),
            "chi2_after": h.get("chi2_per_interval_after"),
            "distance_m": max(route) if route else None}


SUMMARIES = {"info": _info, "solve": _solve, "heldout": _heldout, "diagnose": _diagnose}
