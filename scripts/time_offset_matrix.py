#!/usr/bin/env python3
"""Time-offset matrix of issue 16 (docs/mismatch.md, "Time offsets: the matrix").

Simulated: every drive (config/sims/diff_robot.yaml, forklift.yaml, dual_steer_agv.yaml through
`agvcal simulate`, default trajectory, seed 1) x time offsets 1, 5, 20, 50, 200, 500 ms x
{alone, with a second effect} (`effects: {time_offset: {offset_s: D}}`, the second effect a
longitudinal slip of 0.004 s^2/m, 4-8x its detectable size on these drives). Each recording goes
through `agvcal solve ROBOT LOG --time-offset` and `agvcal diagnose ROBOT LOG`; the table gives
the truth, both estimates, whether each is within 10 % of the truth, and what else diagnose
declared.

Real (--real): every imported recording with a 2D lidar (scripts/import-datasets.sh; the
datasets of ../shared/data) is run as recorded and with injections whose truth is exact: every
SCAN stamp shifted by +37 and +120 ms (--shifts-ms) (tests/tools/shift_scan_stamps.py), and its beam timing
dropped (tests/tools/drop_beam_timing.py). Each injected case is scored against the same
recording without it: the change of the solve and the diagnose estimate against the injected
offset (within 10 %), and the effects diagnose declares that it did not declare before.

  scripts/time_offset_matrix.py [--build DIR] [--work DIR] [--jobs J] [--reuse]
                                [--drives a,b] [--offsets-ms 1,5,...] [--only-alone]
  scripts/time_offset_matrix.py --real [--datasets DIR] [--names mit_csail,mines_exp1]

Prints a markdown table on stdout. Exit status 0 when every row passes, 1 otherwise.
"""
import argparse
import concurrent.futures as cf
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DRIVES = ["diff_robot", "forklift", "dual_steer_agv"]
OFFSETS_MS = [1, 5, 20, 50, 200, 500]
SECOND = ("longitudinal_slip", "longitudinal_slip: {slip_per_accel: 0.004}")
REAL_SHIFTS_MS = [37, 120]


def run(cmd, **kw):
    return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def robot_of(drive):
    with open(os.path.join(HERE, "config", "sims", drive + ".yaml")) as f:
        for line in f:
            if line.startswith("robot:"):
                return os.path.normpath(os.path.join(HERE, "config", "sims", line.split(":", 1)[1].strip()))
    raise SystemExit(f"{drive}: no robot in the sim config")


def solve_and_diagnose(args, robot, log, tag):
    """{solve, solve_std, diag, diag_std, declared, diag_status} of one recording (cached with --reuse)."""
    cache = os.path.join(args.work, tag + ".result.json")
    if args.reuse and os.path.exists(cache):
        with open(cache) as f:
            return json.load(f)
    agvcal = os.path.join(args.build, "agvcal")
    out = {}
    sj, dj = os.path.join(args.work, tag + ".solve.json"), os.path.join(args.work, tag + ".report.json")
    r = run([agvcal, "solve", robot, log, "--time-offset", "--out", sj, "--quiet"])
    if r.returncode == 0:
        with open(sj) as f:
            t = json.load(f)["lidar2d"]["time_offset"]
        out["solve"], out["solve_std"] = t["value"], t["std"]
    else:
        out["solve_error"] = f"exit {r.returncode}: {r.stderr.strip()[:160]}"
    r = run([agvcal, "diagnose", robot, log, "--out", dj, "--quiet", "--jobs", "1"])
    if r.returncode == 0:
        with open(dj) as f:
            rep = json.load(f)
        out["declared"] = {e["name"]: {k: v["value"] for k, v in e["params"].items()} for e in rep.get("effects", [])}
        if "time_offset" in out["declared"]:
            e = next(e for e in rep["effects"] if e["name"] == "time_offset")
            out["diag"], out["diag_std"], out["diag_status"] = e["params"]["offset_s"]["value"], e["params"]["offset_s"]["std"], "found"
        else:
            for c in rep.get("candidates", []):
                if c["name"] == "time_offset":
                    out["diag"], out["diag_std"], out["diag_status"] = c["estimate"]["value"], c["estimate"]["std"], c["status"]
    else:
        out["diag_error"] = f"exit {r.returncode}: {r.stderr.strip()[:160]}"
    with open(cache, "w") as f:
        json.dump(out, f)
    return out


def solve_before(args, robot, log, tag):
    """`solve --time-offset` of the binary in --before-build (diagnose is run by --build only)."""
    sj = os.path.join(args.work, tag + ".solve_before.json")
    r = run([os.path.join(args.before_build, "agvcal"), "solve", robot, log, "--time-offset", "--out", sj, "--quiet"])
    if r.returncode != 0:
        return {"solve_before_error": f"exit {r.returncode}"}
    with open(sj) as f:
        return {"solve_before": json.load(f)["lidar2d"]["time_offset"]["value"]}


def within(est, truth, tol=0.10):
    return est is not None and abs(est - truth) <= tol * abs(truth)


def ms(x, std=None):
    if x is None:
        return "-"
    return f"{x * 1e3:.2f}" + (f" ± {std * 1e3:.2f}" if std is not None else "") + " ms"


def sim_case(args, drive, offset_ms, with_second):
    tag = f"{drive}_{offset_ms}ms_{'slip' if with_second else 'alone'}"
    with open(os.path.join(HERE, "config", "sims", drive + ".yaml")) as f:
        text = f.read()
    text = text.replace("robot: ../robots/", "robot: " + os.path.join(HERE, "config", "robots") + "/")
    text += "effects:\n  time_offset: {offset_s: %g}\n" % (offset_ms * 1e-3)
    if with_second:
        text += "  " + SECOND[1] + "\n"
    sim, log = os.path.join(args.work, tag + ".yaml"), os.path.join(args.work, tag + ".log")
    cache = os.path.join(args.work, tag + ".result.json")
    if args.table_only:
        if not os.path.exists(cache):
            return tag, {"solve_error": "not run", "diag_error": "not run"}
        with open(cache) as f:
            return tag, json.load(f)
    if not (args.reuse and os.path.exists(cache)):
        with open(sim, "w") as f:
            f.write(text)
        r = run([os.path.join(args.build, "agvcal"), "simulate", sim, log, "--quiet"])
        if r.returncode != 0:
            return tag, {"solve_error": "simulate: " + r.stderr.strip()[:160]}
    res = solve_and_diagnose(args, robot_of(drive), log, tag)
    if args.before_build and "solve_before" not in res and os.path.exists(log):
        res.update(solve_before(args, robot_of(drive), log, tag))
        with open(cache, "w") as f:
            json.dump(res, f)
    if os.path.exists(log) and not args.keep_logs:
        os.remove(log)
    return tag, res


def sim_matrix(args):
    cases = [(d, o, s) for d in args.drives for o in args.offsets_ms for s in ([False] if args.only_alone else [False, True])]
    with cf.ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(lambda c: sim_case(args, *c), cases))
    before = "`solve` before | " if args.before_build else ""
    print(f"| drive | second effect | truth | {before}`solve --time-offset` | `diagnose` | within 10 % (solve / diagnose) | declared besides the offset |")
    print("|---|---|---|---|---|---|---|" + ("---|" if args.before_build else ""))
    ok_all = True
    for (drive, o, s), (_, r) in zip(cases, results):
        truth = o * 1e-3
        ok_s, ok_d = within(r.get("solve"), truth), within(r.get("diag"), truth)
        declared = dict(r.get("declared", {}))
        declared.pop("time_offset", None)
        expected = {SECOND[0]} if s else set()
        extra = ", ".join(f"{k} {list(v.values())[0]:.3g}" if v else k for k, v in declared.items()) or "-"
        ok = ok_s and ok_d and r.get("diag_status") == "found" and set(declared) == expected
        ok_all &= ok
        dstat = "" if r.get("diag_status") in (None, "found") else f" ({r['diag_status']})"
        b = ""
        if args.before_build:
            b = (r.get("solve_before_error") or ms(r.get("solve_before"))) + \
                ("" if "solve_before" not in r or within(r["solve_before"], truth) else " (NO)") + " | "
        print(f"| {drive} | {SECOND[0] + ' 0.004' if s else '-'} | {o} ms | {b}"
              f"{r.get('solve_error') or ms(r.get('solve'), r.get('solve_std'))} | "
              f"{r.get('diag_error') or ms(r.get('diag'), r.get('diag_std')) + dstat} | "
              f"{'yes' if ok_s else 'NO'} / {'yes' if ok_d else 'NO'} | {extra} |")
    n = len(cases)
    passed = sum(1 for (d, o, s), (_, r) in zip(cases, results)
                 if within(r.get("solve"), o * 1e-3) and within(r.get("diag"), o * 1e-3))
    print(f"\n{passed} of {n} cases: both estimates within 10 %.")
    return ok_all


def real_matrix(args):
    names = args.names or sorted(n[:-4] for n in os.listdir(args.datasets) if n.endswith(".log"))
    tools = os.path.join(HERE, "tests", "tools")
    rows, ok_all = [], True
    for name in names:
        log = os.path.join(args.datasets, name + ".log")
        r = run(["bash", "-c", f"source '{HERE}/scripts/dataset-robots.bash' && dataset_robot '{name}'"])
        robot = os.path.join(HERE, "config", "robots", "datasets", r.stdout.strip())
        if r.returncode != 0 or not os.path.exists(log):
            print(f"{name}: no {log} or robot file (scripts/dataset-robots.bash); skipped", file=sys.stderr)
            continue
        with open(robot) as f:
            if "lidar2d:" not in f.read():
                continue  # no 2D lidar: no scans to shift
        cases = [("as recorded", log, None)]
        for shift in args.shifts_ms:
            shift *= 1e-3
            out = os.path.join(args.work, f"{name}_shift{round(shift * 1e3)}.log")
            if not os.path.exists(out):
                r = run([sys.executable, os.path.join(tools, "shift_scan_stamps.py"), log, out, str(shift)])
                if r.returncode != 0:
                    raise SystemExit(r.stderr)
            cases.append((f"SCAN {round(shift * 1e3):+d} ms", out, shift))
        out = os.path.join(args.work, f"{name}_notiming.log")
        if not os.path.exists(out):
            r = run([sys.executable, os.path.join(tools, "drop_beam_timing.py"), log, out])
            if r.returncode != 0:
                raise SystemExit(r.stderr)
        cases.append(("beam timing dropped", out, 0.0))
        with cf.ThreadPoolExecutor(args.jobs) as pool:
            res = list(pool.map(lambda c: solve_and_diagnose(args, robot, c[1], f"{name}_{os.path.basename(c[1])[:-4]}"), cases))
        base = res[0]
        for (label, _, shift), r in zip(cases, res):
            before = set(base.get("declared", {}))
            new = sorted(set(r.get("declared", {})) - before)
            gone = sorted(before - set(r.get("declared", {})))
            if shift is None:
                verdict = "-"
                ds = dd = "-"
            else:
                ds = None if "solve" not in r or "solve" not in base else r["solve"] - base["solve"]
                dd = None if "diag" not in r or "diag" not in base else r["diag"] - base["diag"]
                if shift == 0.0:
                    ok_s = ds is not None and abs(ds) <= 0.01 * max(abs(base["solve"]), 1e-3) + 2 * r["solve_std"]
                    ok_d = dd is not None and abs(dd) <= 0.1 * max(abs(base["diag"]), 1e-3)
                else:
                    ok_s, ok_d = within(ds, shift), within(dd, shift)
                ok = ok_s and ok_d and not new
                ok_all &= ok
                verdict = ("yes" if ok_s else "NO") + " / " + ("yes" if ok_d else "NO") + ("" if not new else " (new effect)")
                ds, dd = ("-" if ds is None else f"{ds * 1e3:+.1f} ms"), ("-" if dd is None else f"{dd * 1e3:+.1f} ms")
            decl = ", ".join(f"{k} {list(v.values())[0]:.3g}" if v else k for k, v in r.get("declared", {}).items()) or "-"
            rows.append(f"| {name} | {label} | {r.get('solve_error') or ms(r.get('solve'), r.get('solve_std'))} | {ds} | "
                        f"{r.get('diag_error') or ms(r.get('diag'), r.get('diag_std'))} | {dd} | {verdict} | {decl} | "
                        f"{', '.join(new) or '-'}{'; gone: ' + ', '.join(gone) if gone else ''} |")
    print("| recording | injection | `solve --time-offset` | change | `diagnose` offset | change | recovered within 10 % (solve / diagnose) | diagnose declares | newly declared |")
    print("|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    return ok_all


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--build", default=os.path.join(HERE, "build"), help="build directory with agvcal (default build/)")
    p.add_argument("--work", default=None, help="directory for logs and results (default: a temporary one)")
    p.add_argument("--jobs", type=int, default=1, help="recordings at once (default 1)")
    p.add_argument("--reuse", action="store_true", help="reuse results already in --work")
    p.add_argument("--before-build", default=None,
                   help="also run `solve --time-offset` of the agvcal in this directory (a column 'before')")
    p.add_argument("--table-only", action="store_true",
                   help="print the table of the results already in --work; run nothing")
    p.add_argument("--keep-logs", action="store_true", help="keep the simulated logs")
    p.add_argument("--drives", default=",".join(DRIVES), help="comma-separated drives (default all three)")
    p.add_argument("--offsets-ms", default=",".join(map(str, OFFSETS_MS)), help="comma-separated offsets in ms")
    p.add_argument("--only-alone", action="store_true", help="no cases with a second effect")
    p.add_argument("--real", action="store_true", help="the real recordings with injected shifts instead")
    p.add_argument("--datasets", default=None,
                   help="directory of imported recordings NAME.log with NAME.yaml (scripts/import-datasets.sh)")
    p.add_argument("--shifts-ms", default=",".join(map(str, REAL_SHIFTS_MS)),
                   help="--real: comma-separated SCAN stamp shifts in ms (default 37,120)")
    p.add_argument("--names", default=None, help="comma-separated recordings of --datasets (default: all)")
    args = p.parse_args()
    args.drives = args.drives.split(",")
    args.offsets_ms = [float(x) if "." in x else int(x) for x in args.offsets_ms.split(",")]
    args.names = args.names.split(",") if args.names else None
    args.shifts_ms = [int(x) for x in args.shifts_ms.split(",")]
    if args.work is None:
        import tempfile
        args.work = tempfile.mkdtemp(prefix="time_offset_matrix_")
    os.makedirs(args.work, exist_ok=True)
    if args.real:
        if not args.datasets:
            raise SystemExit("--real needs --datasets DIR (scripts/import-datasets.sh DIR)")
        ok = real_matrix(args)
    else:
        ok = sim_matrix(args)
    print(f"(work directory {args.work})", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
