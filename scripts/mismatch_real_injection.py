#!/usr/bin/env python3
"""Real-data injection suite for `agvcal diagnose` (docs/mismatch-real-injection.md), beside the
randomized suite (scripts/mismatch_suite.py).

Every real recording of ../shared/data (scripts/import-datasets.sh, robot files by
scripts/dataset-robots.bash), lidar and pose sources alike, is diagnosed as recorded; then effects
of exactly known size are written into it (scripts/inject_effect.py: exact in the diagnosis's own
terms, tests/inject_effect_test.cc) and it is diagnosed again:
- longitudinal_slip (every wheel, the recording's calibrated radii),
- wheel_eccentricity of the first wheel as a phase pair, p and p + pi: the half difference of the
  two estimates (amplitude x (cos, sin) of the phase) is the injection, the recording's own
  eccentricity cancels from it,
- a wheel-clock offset (every WHEELS stamp moved) and a scan-clock offset (every SCAN or POSE stamp
  moved), both signs: the time offset changes by -D and +D,
- steering_backlash on a steered drive,
each at 3x and 10x the larger of the effect's `detectable` and `detectable_with` in the
recording's unmodified REPORT.json. A size the effect's model cannot realise on the recording
(an eccentricity amplitude >= 1, a slip whose slip x acceleration reaches 1), and an offset that
takes the recording's own beyond the +-2 s the diagnosis searches, are listed, not run.

Scored against the same recording unmodified: recovered = the effect named (in `effects`) with
the change of its estimate within 15 % of the injection or 2 sigma; clean = every other declared
effect within 2 sigma of its as-recorded estimate (declared or single-fit).

  scripts/mismatch_real_injection.py [--build DIR] [--work DIR] [--jobs J] [--quick]
                                     [--multiples 3,10] [--one-sign] [--names a,b]
                                     [--compare /work/main/build] [--effects time_offset] [--injector PATH]
                                     [--score-only] [--out FILE]
--quick: 3x only, one sign of each offset, three recordings (mines_exp1, lego_robot4, the first
OptiOdom tricycle run): for iteration. Prints the Markdown table (and writes it to --out).
"""
import argparse
import concurrent.futures as cf
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MULTIPLES = (3, 10)
ECC_PHASE = 0.4  # rad; the pair's second run at ECC_PHASE + pi
SEARCHED_OFFSET_S = 2.0  # the diagnosis's offset search range (calibration.h kWidestTimeOffsetS)
QUICK_NAMES = ("mines_exp1", "lego_robot4", "optiodom_tricycle_circular_140120211415_run-01")
KEY = {"longitudinal_slip": "slip_per_accel", "wheel_eccentricity": "amplitude", "time_offset": "offset_s",
       "steering_backlash": "width_rad"}


def dataset_robot(name):
    r = subprocess.run(["bash", "-c", f'source "{HERE}/scripts/dataset-robots.bash"; dataset_robot "$0"', name],
                       stdout=subprocess.PIPE, text=True)
    return os.path.join(HERE, "config", "robots", "datasets", r.stdout.strip()) if r.returncode == 0 else None


def diagnose(args, robot, log, out):
    """The parsed REPORT.json of `log` (cached in `out`), or {"error": ...}."""
    if os.path.exists(out):
        with open(out) as f:
            return json.load(f)
    if args.score_only:
        return {"not_run": "not run in the time the run had"}
    r = subprocess.run([os.path.join(args.build, "agvcal"), "diagnose", robot, log, "--out", out, "--quiet",
                        "--jobs", "1"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        rep = {"error": f"exit {r.returncode}: {r.stderr.strip().splitlines()[-1][:160] if r.stderr.strip() else ''}"}
    else:
        with open(out) as f:
            rep = json.load(f)
        rep.pop("intervals", None)
    with open(out, "w") as f:
        json.dump(rep, f)
    return rep


def candidate(rep, name, wheel=""):
    for c in rep.get("candidates", []):
        if c["name"] == name and (c.get("wheel") or "") == wheel:
            return c
    return None


def declared(rep, name, wheel=""):
    for e in rep.get("effects", []):
        if e["name"] == name and (e.get("wheel") or "") == wheel:
            return e
    return None


def estimate(rep, name, wheel=""):
    """(value, sigma) of the effect's size: the declared one, else the single fit's."""
    e = declared(rep, name, wheel)
    if e is not None:
        p = e["params"][KEY.get(name, next(iter(e["params"])))] if KEY.get(name) in e["params"] else next(iter(e["params"].values()))
        return p["value"], p["std"]
    c = candidate(rep, name, wheel)
    return (c["estimate"]["value"], c["estimate"]["std"]) if c else (0.0, math.inf)


def ecc_vector(rep, wheel):
    """(c, s, sigma) of a declared eccentricity, None when not declared."""
    e = declared(rep, "wheel_eccentricity", wheel)
    if e is None:
        return None
    a, ph = e["params"]["amplitude"], e["params"]["phase"]["value"]
    return a["value"] * math.cos(ph), a["value"] * math.sin(ph), a["std"]


def unit_size(base, name, wheel=""):
    c = candidate(base, name, wheel)
    if c is None:
        return None
    return max([c["detectable"]] + list(c.get("detectable_with", {}).values()))


def plan(base, name, robot, args):
    """The injections of one recording: dicts with tag, effect, args (inject_effect.py), truth."""
    drive, roles = base["drive"], list(read_roles(robot))
    wheel0 = roles[0]
    source_channel = "SCAN" if any(k.startswith("lidar2d") for k in base["calibration"]) else "POSE"
    params = base.get("refitted") or base["calibration"]
    radii = ",".join(f"{params[r + '_radius']['value']:.9g}" for r in roles)
    out = []
    for m in args.multiples:
        s = unit_size(base, "longitudinal_slip")
        if s:
            out.append({"tag": f"slip_{m}x", "effect": "longitudinal_slip", "wheel": "", "size": m * s, "x": m,
                        "runs": [["slip", f"{m * s:.6g}", radii]]})
        a = unit_size(base, "wheel_eccentricity", wheel0)
        if a:
            out.append({"tag": f"ecc_{m}x", "effect": "wheel_eccentricity", "wheel": wheel0, "size": m * a, "x": m,
                        "runs": [["eccentricity", wheel0, f"{m * a:.6g}", str(ECC_PHASE)],
                                 ["eccentricity", wheel0, f"{m * a:.6g}", str(ECC_PHASE + math.pi)]]})
        d = unit_size(base, "time_offset")
        recorded = estimate(base, "time_offset")[0]
        if d:
            for sign in (1,) if args.one_sign else (1, -1):
                shift = sign * m * d
                for clock, channel, change in (("wheelclock", "WHEELS", -shift), ("scanclock", source_channel, shift)):
                    inj = {"tag": f"{clock}_{'+' if sign > 0 else '-'}{m}x", "effect": "time_offset", "wheel": "",
                           "size": change, "x": m, "runs": [["offset", channel, f"{shift:.6f}"]]}
                    if abs(recorded + change) > SEARCHED_OFFSET_S:
                        inj["skip"] = (f"the offset with it, {recorded + change:.3g} s, lies beyond the "
                                       f"+-{SEARCHED_OFFSET_S:g} s searched")
                    out.append(inj)
        if drive != "differential":
            w = unit_size(base, "steering_backlash")
            if w:
                out.append({"tag": f"backlash_{m}x", "effect": "steering_backlash", "wheel": "", "size": m * w, "x": m,
                            "runs": [["backlash", wheel0, f"{m * w:.6g}"]]})
    return out


def read_roles(robot):
    import yaml
    with open(robot) as f:
        return dict(yaml.safe_load(f)["wheels"])


def run_injection(args, name, robot, log, inj):
    """Injects and diagnoses each run of `inj`; the reports, or a reason it was not run."""
    if "skip" in inj:
        return {"not_run": inj["skip"]}
    reps = []
    for k, run in enumerate(inj["runs"]):
        tag = f"{name}.{inj['tag']}.{k}"
        out = os.path.join(args.work, args.label, tag + ".json")
        if not os.path.exists(out) and not args.score_only:
            injected = os.path.join(args.work, args.label, tag + ".log")
            r = subprocess.run([sys.executable, args.injector, log, injected, robot]
                               + run, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            if r.returncode == 3:
                return {"not_run": r.stderr.strip().split("not realisable: ")[-1]}
            if r.returncode != 0:
                return {"not_run": f"inject_effect.py exit {r.returncode}: {r.stderr.strip()[-160:]}"}
            rep = diagnose(args, robot, injected, out)
            os.path.exists(injected) and os.remove(injected)
        else:
            rep = diagnose(args, robot, None, out)
        if "not_run" in rep:
            return rep
        reps.append(rep)
    return {"reports": reps}


def score(base, inj, result):
    """Adds found, change, sigma, recovered, moved (other effects beyond 2 sigma) to `inj`."""
    inj.update(found="-", change=None, sigma=None, recovered=False, moved=[], note="")
    if "not_run" in result:
        inj["note"] = "not run: " + result["not_run"]
        return
    reps = result["reports"]
    errors = [r["error"] for r in reps if "error" in r]
    if errors:
        inj["note"] = errors[0]
        return
    name, wheel, truth = inj["effect"], inj["wheel"], inj["size"]
    named = all(declared(r, name, wheel) is not None for r in reps)
    inj["found"] = "yes" if named else "no"
    if name == "wheel_eccentricity":
        vs = [ecc_vector(r, wheel) for r in reps]
        if all(vs):
            dc, ds = (vs[0][0] - vs[1][0]) / 2, (vs[0][1] - vs[1][1]) / 2
            inj["sigma"] = math.hypot(vs[0][2], vs[1][2]) / 2
            # Its size along the injected phase, and the error as the whole vector's.
            inj["change"] = dc * math.cos(ECC_PHASE) + ds * math.sin(ECC_PHASE)
            err = math.hypot(dc - truth * math.cos(ECC_PHASE), ds - truth * math.sin(ECC_PHASE))
        else:
            v = [estimate(r, name, wheel)[0] for r in reps]
            inj["change"], err = 0.5 * (v[0] + v[1]) - estimate(base, name, wheel)[0], math.inf
    else:
        v, sd = estimate(reps[0], name, wheel)
        inj["change"], inj["sigma"] = v - estimate(base, name, wheel)[0], sd
        err = abs(inj["change"] - truth)
    inj["recovered"] = named and (err <= 0.15 * abs(truth) or err <= 2 * (inj["sigma"] or 0))
    for r in reps:
        for e in r.get("effects", []):
            if e["name"] == name and (e.get("wheel") or "") == wheel:
                continue
            v, sd = estimate(r, e["name"], e.get("wheel") or "")
            b, sb = estimate(base, e["name"], e.get("wheel") or "")
            if abs(v - b) > 2 * math.hypot(sd, sb if math.isfinite(sb) else 0):
                label = e["name"] + (f" ({e['wheel']})" if e.get("wheel") else "")
                if label not in inj["moved"]:
                    inj["moved"].append(f"{label} {b:.3g} → {v:.3g} ± {sd:.2g}")


def fmt(x):
    return "-" if x is None else f"{x:.3g}"


def table(rows, label):
    out = ["| recording | injection | size (x the detectable) | named | change found ± σ | recovered | other effects moved beyond 2σ | note |",
           "|---|---|---|---|---|---|---|---|"]
    for name, inj in rows:
        wheel = f" ({inj['wheel']})" if inj["wheel"] else ""
        out.append(f"| {name} | {inj['tag'].split('_')[0]} {inj['effect']}{wheel} | {inj['size']:.3g} ({inj['x']}x) | "
                   f"{inj['found']} | {fmt(inj['change'])} ± {fmt(inj['sigma'])} | {'yes' if inj['recovered'] else 'no'} | "
                   f"{'; '.join(inj['moved']) or '-'} | {inj['note']} |")
    out.insert(0, summary(rows, label) + "\n")
    return "\n".join(out) + "\n"


def ran(inj):
    return not inj["note"].startswith("not run")


def summary(rows, label):
    done = [i for _, i in rows if ran(i)]
    late = sum(1 for _, i in rows if "in the time" in i["note"])
    rec = sum(i["recovered"] for i in done)
    clean = sum(not i["moved"] and not i["note"] for i in done)
    by_effect = {}
    for i in done:
        t = by_effect.setdefault(i["effect"], [0, 0])
        t[0] += i["recovered"]
        t[1] += 1
    return (f"**{label}: recovered {rec} of {len(done)} injections run; {clean} of {len(done)} with nothing else "
            f"moved beyond 2σ.** Not run: {len(rows) - len(done) - late} sizes not realisable on their recording or "
            f"beyond the offset range searched, {late} not run in the time the run had. By effect: "
            + ", ".join(f"{k} {a} of {b}" for k, (a, b) in sorted(by_effect.items())) + ".")


def side_by_side(rows_a, rows_b, label_a, label_b):
    """One row per injection both builds ran (each at its own size): the change each found, named, recovered."""
    both = [(n, a, b) for (n, a), (_, b) in zip(rows_a, rows_b) if ran(a) and ran(b)]
    out = [summary([(n, a) for n, a, _ in both], f"{label_a}, the injections both ran"),
           "", summary([(n, b) for n, _, b in both], f"{label_b}, the injections both ran"), "",
           f"| recording | injection | injected ({label_a}; {label_b}) | {label_a}: change ± σ, named, recovered | {label_b}: change ± σ, named, "
           f"recovered | {label_b}: other effects moved beyond 2σ | {label_b}: note |",
           "|---|---|---|---|---|---|---|"]
    for n, a, b in both:
        wheel = f" ({a['wheel']})" if a["wheel"] else ""
        cell = lambda i: f"{fmt(i['change'])} ± {fmt(i['sigma'])}, {i['found']}, {'**yes**' if i['recovered'] else 'no'}"
        out.append(f"| {n} | {a['tag'].split('_')[0]} {a['effect']}{wheel} | {a['size']:.3g}; {b['size']:.3g} ({a['x']}x) | {cell(a)} | "
                   f"{cell(b)} | {'; '.join(b['moved']) or '-'} | {b['note'][:140]} |")
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("AGVCAL_BIN", os.path.join(HERE, "build")))
    ap.add_argument("--work", default="/tmp/agvcal-real-injection")
    ap.add_argument("--label", default=None, help="subfolder of --work for this build's reports")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--names", default="")
    ap.add_argument("--out", default="")
    ap.add_argument("--multiples", default="3,10", help="sizes, in multiples of the detectable size")
    ap.add_argument("--one-sign", action="store_true", help="each clock moved one way only (the time offset "
                    "still changes both ways: a later wheel clock lowers it, a later scan clock raises it)")
    ap.add_argument("--injector", default=os.path.join(HERE, "scripts", "inject_effect.py"),
                    help="the injector (another build's version: exact in its speeds)")
    ap.add_argument("--effects", default="", help="only these injected effects (e.g. time_offset), comma-separated")
    ap.add_argument("--score-only", action="store_true", help="score the reports there are; run nothing")
    ap.add_argument("--compare", default="", help="another build (e.g. /work/main/build) whose reports under "
                    "--work are scored beside: the injections both ran, side by side")
    args = ap.parse_args()
    args.multiples = [int(m) for m in args.multiples.split(",")]
    if args.quick:
        args.multiples, args.one_sign = args.multiples[:1], True
    args.build = os.path.abspath(args.build)
    args.label = args.label or args.build.strip("/").replace("/", "_")
    rec_dir = os.path.join(args.work, "recordings")
    os.makedirs(os.path.join(args.work, args.label), exist_ok=True)
    if not (os.path.isdir(rec_dir) and any(f.endswith(".log") for f in os.listdir(rec_dir))):
        subprocess.run([os.path.join(HERE, "scripts", "import-datasets.sh"), rec_dir], check=True,
                       env=dict(os.environ, AGVCAL_BIN=args.build), stdout=subprocess.DEVNULL)
    names = sorted(f[:-4] for f in os.listdir(rec_dir) if f.endswith(".log"))
    wanted = args.names.split(",") if args.names else (QUICK_NAMES if args.quick else names)
    names = [n for n in wanted if n in names and dataset_robot(n)]  # in the order asked
    logs = {n: os.path.join(rec_dir, n + ".log") for n in names}
    with cf.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        bases = dict(zip(names, pool.map(
            lambda n: diagnose(args, dataset_robot(n), logs[n], os.path.join(args.work, args.label, n + ".json")),
            names)))
        work = []
        for n in names:
            if "error" in bases[n] or "not_run" in bases[n]:
                print(f"{n}: as recorded: {bases[n].get('error') or bases[n]['not_run']}", file=sys.stderr)
                continue
            work += [(n, inj) for inj in plan(bases[n], n, dataset_robot(n), args)
                     if not args.effects or inj["effect"] in args.effects.split(",")]
        results = list(pool.map(lambda w: run_injection(args, w[0], dataset_robot(w[0]), logs[w[0]], w[1]), work))
    for (n, inj), res in zip(work, results):
        score(bases[n], inj, res)
    text = table(work, f"{args.build}/agvcal")
    if args.compare:
        import copy
        other = copy.copy(args)
        other.build, other.label, other.score_only = args.compare, args.compare.strip("/").replace("/", "_"), True
        base_b = {n: diagnose(other, None, None, os.path.join(args.work, other.label, n + ".json")) for n in names}
        # Each build's own sizes (its own as-recorded detectable), paired by injection.
        work_b = []
        for n, inj in work:
            mine = [i for i in plan(base_b[n], n, dataset_robot(n), args) if i["tag"] == inj["tag"]] \
                if "error" not in base_b[n] and "not_run" not in base_b[n] else []
            b = mine[0] if mine else dict(inj)
            if mine:
                score(base_b[n], b, run_injection(other, n, dataset_robot(n), logs[n], b))
            else:
                score(bases[n], b, {"not_run": "not run on that build"})
            work_b.append((n, b))
        text = side_by_side(work_b, work, args.compare, args.build) + "\n" + text
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
