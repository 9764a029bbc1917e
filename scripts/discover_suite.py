#!/usr/bin/env python3
"""Physics outside the catalogue (docs/effects.md "Discovered physics"): simulated recordings with
a planted term (sim config `terms:`) at several sizes, physics the library has no term for, and
controls, each diagnosed blind; prints a Markdown table (truth against what was discovered, the
verdict, the misfit) and the tallies.

  scripts/discover_suite.py [--seeds N] [--jobs J] [--quick] [--only planted|outside|controls]

Randomized mode (--random N): N recordings per drive, each with the randomized suite's sensors,
world and start drawn from its seed (scripts/mismatch_suite.py), a fifth of them controls, the
rest one family of physics drawn at random (FAMILIES: the library's terms and physics outside the
library) at 1x-20x its detectable size (from pilot recordings, `detectable`), with a random sign;
writes the figures and the table of docs/discover.md to --out.

  scripts/discover_suite.py --random 60 [--first-seed S] [--drives diff_robot,forklift] [--work DIR] [--out F]
"""
import argparse
import concurrent.futures as cf
import hashlib
import json
import math
import os
import random
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
AGVCAL = os.path.join(os.environ.get("AGVCAL_BIN", os.path.join(HERE, "build")), "agvcal")
sys.path.insert(0, os.path.join(HERE, "scripts"))

# (sim, channel, regressor, coefficients, in the library)
PLANTED = [
    ("diff_robot", "yaw_rate", "turn_rate*|turn_rate|", [-0.05, -0.1, -0.2], True),
    ("diff_robot", "radius", "|speed|", [0.01, 0.02, 0.04], True),
    ("diff_robot", "yaw_rate", "turn_rate*|speed|", [-0.05, -0.1, -0.2], True),
    ("forklift", "steer", "steer*|steer|", [0.1, 0.2, 0.4], True),
    ("forklift", "yaw_rate", "turn_rate*|turn_rate|", [-0.05, -0.1, -0.2], True),
    ("diff_robot", "yaw_rate", "time", [1e-4, 2e-4], False),
    ("diff_robot", "yaw_rate", "turn_rate^3", [-0.1, -0.2], False),
]
CONTROLS = ["diff_robot", "forklift"]


def run(case, work):
    sim, channel, regressor, coef, seed = case
    tag = f"{sim}_{channel}_{regressor}_{coef}_{seed}".replace("|", "a").replace("*", "x").replace("^", "p")
    cfg = os.path.join(work, tag + ".yaml")
    base = open(os.path.join(HERE, "config/sims", sim + ".yaml")).read()
    base = base.replace("robot: ../robots/", "robot: " + os.path.join(HERE, "config/robots") + "/")
    with open(cfg, "w") as f:
        f.write(base)
        if channel:
            f.write(f'terms:\n  - {{channel: {channel}, regressor: "{regressor}", coefficient: {coef}}}\n')
    log, out = os.path.join(work, tag + ".log"), os.path.join(work, tag + ".json")
    subprocess.run([AGVCAL, "simulate", cfg, log, "--seed", str(seed), "--quiet"], check=True)
    subprocess.run([AGVCAL, "diagnose", os.path.join(HERE, "config/robots", sim + ".yaml"), log, "--out", out,
                    "--quiet"], check=True, stdout=subprocess.DEVNULL)
    os.remove(log)
    return case, json.load(open(out))


# The randomized suite (--random N). Families of physics per drive: (channel, regressor, size
# the pilot plants, in the library). Outside the library: physics the library was not built
# around (a yaw rate by ω³, by ω², by the time since start; a radius by v², by signed v, by time;
# a steering angle drifting with time).
FAMILIES = {
    "diff_robot": [
        ("yaw_rate", "turn_rate*|turn_rate|", -0.05, True), ("yaw_rate", "turn_rate*|speed|", -0.05, True),
        ("yaw_rate", "|turn_rate|", 0.01, True), ("radius", "|speed|", 0.01, True), ("radius", "turn_rate^2", 0.01, True),
        ("timing", "time", 2e-5, True),
        ("yaw_rate", "turn_rate^3", -0.05, False), ("yaw_rate", "turn_rate^2", -0.02, False),
        ("yaw_rate", "time", 2e-5, False), ("radius", "speed^2", 0.01, False), ("radius", "speed", 0.005, False),
        ("radius", "time", 2e-5, False)],
    "forklift": [
        ("yaw_rate", "turn_rate*|turn_rate|", -0.05, True), ("yaw_rate", "turn_rate*|speed|", -0.05, True),
        ("yaw_rate", "|turn_rate|", 0.01, True), ("radius", "|speed|", 0.01, True), ("radius", "turn_rate^2", 0.01, True),
        ("timing", "time", 2e-5, True),
        ("steer", "steer*|steer|", 0.1, True), ("steer", "steer^2", 0.05, True), ("steer", "steer*|speed|", -0.05, True),
        ("yaw_rate", "turn_rate^3", -0.05, False), ("yaw_rate", "time", 2e-5, False),
        ("radius", "speed^2", 0.01, False), ("radius", "speed", 0.005, False), ("steer", "time", 2e-5, False)],
}
# The Wald z a term needs to be found with power 0.8: Holm's first level over the library
# (alpha 0.01 over up to 8 terms, two-sided) plus the 80 % quantile.
Z_DETECT = 4.07


def cell(text):
    """Text for a Markdown table cell (the regressors' names hold '|')."""
    return str(text).replace("|", "\\|")


def terms_yaml(channel, regressor, coef):
    return f'terms:\n  - {{channel: {channel}, regressor: "{regressor}", coefficient: {coef:.6g}}}\n'


def recording_tag(drive, seed, terms):
    return f"{drive}_{seed}_" + hashlib.sha1(terms.encode()).hexdigest()[:8]


def random_recording(drive, seed, work, terms, run=True):
    """The randomized suite's recording of `seed` (sensors, world, start from mismatch_suite),
    with `terms`, simulated and diagnosed blind: its REPORT.json (without intervals, with their
    count on the fit blocks as `fit_rows`) or {"error": ...}."""
    import mismatch_suite as ms
    rng = random.Random(f"{drive}-{seed}")
    sensors = ms.random_sensors(rng, drive)
    world = os.path.join(work, f"{drive}_{seed}.world")
    ms.random_world(rng, world)
    tag = recording_tag(drive, seed, terms)
    out = os.path.join(work, tag + ".json")
    if os.path.exists(out):
        return json.load(open(out)), sensors
    if not run:
        return {"error": "not run"}, sensors
    cfg, log = os.path.join(work, tag + ".yaml"), os.path.join(work, tag + ".log")
    with open(cfg, "w") as f:
        f.write(ms.random_sim_text(drive, seed, sensors, world, []) + terms)
    r = subprocess.run([AGVCAL, "simulate", cfg, log, "--quiet"], stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, text=True)
    if r.returncode:
        return {"error": f"simulate exit {r.returncode}: {r.stderr.strip()[:200]}"}, sensors
    r = subprocess.run([AGVCAL, "diagnose", os.path.join(HERE, "config/robots", ms.drive_robot(drive)), log,
                        "--out", out, "--write-sim", os.path.join(work, tag + ".sim.yaml"), "--quiet"],
                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    os.remove(log)
    if r.returncode:
        return {"error": f"diagnose exit {r.returncode}: {r.stderr.strip()[:200]}"}, sensors
    rep = json.load(open(out))
    rep["fit_rows"] = sum(1 for i in rep.pop("intervals") if not i["heldout"] and not i["outlier"])
    json.dump(rep, open(out, "w"))
    return rep, sensors


def found_term(rep, channel, regressor):
    return next((d for d in rep.get("discovered", []) if d["channel"] == channel
                 and d["terms"][0]["regressor"] == regressor), None)


def detectable(rep, control, channel, regressor, size):
    """The size a term needs to be found with power 0.8, from a pilot recording planted at `size`:
    Z_DETECT over the found term's Wald z (or the z the report's note gives it when it was not
    confirmed); for physics outside the library, over the z of its found look-alike or, with none
    found, over the square root of the chi-square it adds beyond the control's (variance factor ×
    fit rows, at least 1)."""
    d = found_term(rep, channel, regressor) or (rep.get("discovered") or [None])[0]
    left = f"strongest library term left, {channel} by {regressor} (Wald z "
    note = next((n for n in rep.get("notes", []) if left in n), None)
    if d:
        c = d["terms"][0]["coefficient"]
        z = abs(c["value"] / c["std"])
    elif note:  # not confirmed (a catalogued look-alike took it): its Wald z from the note
        z = abs(float(note.split(left)[1].split(",")[0]))
    else:
        excess = (rep["misfit"]["variance_factor"] - control["misfit"]["variance_factor"]) * 3 * rep["fit_rows"]
        z = math.sqrt(max(excess, 1.0))
    return abs(size) * Z_DETECT / z


def random_suite(a, pool):
    drives = a.drives.split(",")
    pilot = {}
    jobs = {}
    for d in drives:  # 1. pilots: each family planted at its pilot size, and a control, on seed 900000
        jobs[pool.submit(random_recording, d, 900000, a.work, "")] = (d, None)
        for fam in FAMILIES[d]:
            jobs[pool.submit(random_recording, d, 900000, a.work, terms_yaml(fam[0], fam[1], fam[2]))] = (d, fam)
    for fut in cf.as_completed(jobs):
        pilot[jobs[fut]] = fut.result()[0]
    det = {}
    for d in drives:
        for fam in FAMILIES[d]:
            det[(d, fam[1], fam[0])] = detectable(pilot[(d, fam)], pilot[(d, None)], *fam[:3])
    cases = []
    for d in drives:  # 2. the recordings: a fifth controls, the rest a family at 1x-20x
        for seed in range(a.first_seed, a.first_seed + a.random):
            rng = random.Random(f"discover-{d}-{seed}")
            if rng.random() < a.controls:
                cases.append((d, seed, None, 0.0, None))
                continue
            fam = rng.choice(FAMILIES[d])
            mult = math.exp(rng.uniform(0, math.log(20)))
            coef = math.copysign(mult * det[(d, fam[1], fam[0])], fam[2] * rng.choice([1, -1]))
            cases.append((d, seed, fam, float(f"{coef:.3g}"), mult))
    cases.sort(key=lambda c: (c[1], c[0]))  # the drives interleaved: a run cut short keeps both
    futs = [pool.submit(random_recording, d, seed, a.work, terms_yaml(fam[0], fam[1], coef) if fam else "",
                        not a.no_run) for d, seed, fam, coef, _ in cases]
    rows = []
    for case, fut in zip(cases, futs):
        rep, sensors = fut.result()
        if rep.get("error") != "not run":
            rows.append(score_random(case, rep, sensors))
    return rows, det


def sim_loop(a, rows, pool):
    """The sim-to-real loop on the first --loop recordings whose planted library term was found
    right: the config their diagnosis wrote (--write-sim: the refitted calibration, the effects
    and the terms; the simulator's default sensors and world) simulated with another seed and
    diagnosed; the same term within 2 sigma (of the difference) or 5 %?"""
    picked = [r for r in rows if r.get("right")][:a.loop]
    def one(r):
        fam = r["family"]
        tag = recording_tag(r["drive"], r["seed"], terms_yaml(fam[0], fam[1], r["coef"]))
        cfg, log = os.path.join(a.work, tag + ".sim.yaml"), os.path.join(a.work, tag + ".loop.log")
        out = os.path.join(a.work, tag + ".loop.json")
        if not os.path.exists(out):
            robot = next(l.split(":", 1)[1].strip() for l in open(cfg) if l.startswith("robot:"))
            subprocess.run([AGVCAL, "simulate", cfg, log, "--seed", str(r["seed"] + 7), "--quiet"], check=True)
            subprocess.run([AGVCAL, "diagnose", robot, log, "--out", out, "--quiet"], check=True,
                           stdout=subprocess.DEVNULL)
            os.remove(log)
        return r, json.load(open(out))
    lines = ["", "Sim-to-real loop (`diagnose --write-sim`, `simulate --seed S+7`, `diagnose`):", "",
             "| drive | seed | term | found on the recording | found on the re-simulated one | within |",
             "|---|---|---|---|---|---|"]
    n_ok = 0
    for r, rep in pool.map(one, picked):
        fam = r["family"]
        c1 = next(x for x in r["discovered"] if x[0] == fam[0] and x[1] == fam[1])
        hit = found_term(rep, fam[0], fam[1])
        c2 = (hit["terms"][0]["coefficient"]["value"], hit["terms"][0]["coefficient"]["std"]) if hit else None
        ok = bool(c2) and abs(c2[0] - c1[2]) <= max(2 * math.hypot(c1[3], c2[1]), 0.05 * abs(c1[2]))
        n_ok += ok
        again = f"{c2[0]:.4g} ± {c2[1]:.2g}" if c2 else "not found (" + rep["verdict"] + ")"
        lines.append(f"| {r['drive']} | {r['seed']} | {cell(fam[0] + ': ' + fam[1])} | {c1[2]:.4g} ± {c1[3]:.2g} | {again} | "
                     f"{'yes' if ok else 'no'} |")
    lines.insert(1, f"Sim-to-real loop: the same term within 2 sigma or 5 % on {n_ok}/{len(picked)} re-simulated recordings.")
    return "\n".join(lines) + "\n"


def score_random(case, rep, sensors):
    d, seed, fam, coef, mult = case
    row = {"drive": d, "seed": seed, "family": fam, "coef": coef, "mult": mult, "sensors": sensors,
           "error": rep.get("error")}
    if row["error"]:
        return row
    row.update(verdict=rep["verdict"], vf=rep["misfit"]["variance_factor"],
               ratio=rep["misfit"]["heading_drift_ratio"], effects=[e["name"] for e in rep["effects"]],
               discovered=[(x["channel"], x["terms"][0]["regressor"], x["terms"][0]["coefficient"]["value"],
                            x["terms"][0]["coefficient"]["std"]) for x in rep["discovered"]])
    if fam and fam[3]:
        hit = found_term(rep, fam[0], fam[1])
        row["right"] = bool(hit) and len(rep["discovered"]) == 1
        if hit:
            c = hit["terms"][0]["coefficient"]
            row["own_mult"] = abs(coef) / (Z_DETECT * c["std"])
            row["within"] = abs(c["value"] - coef) <= max(0.2 * abs(coef), 2 * c["std"])
            h = hit["heldout_drift"]
            row["heldout30"] = h["rms_after"] <= 0.7 * h["rms_before"]
    return row


def random_report(a, rows, det):
    pct = lambda k, n: f"{100.0 * k / n:.1f} % ({k}/{n})" if n else "-"
    ok = [r for r in rows if not r["error"]]
    ctrl = [r for r in ok if not r["family"]]
    lib = [r for r in ok if r["family"] and r["family"][3]]
    out = [r for r in ok if r["family"] and not r["family"][3]]
    mult = lambda r: r.get("own_mult") or r["mult"]
    lib3 = [r for r in lib if mult(r) >= 3]
    lib13 = [r for r in lib if mult(r) < 3]
    right = [r for r in lib if r.get("right")]
    median_vf = {}
    for d in {r["drive"] for r in ctrl}:
        v = sorted(r["vf"] for r in ctrl if r["drive"] == d)
        median_vf[d] = v[len(v) // 2]
    far = [r for r in ok if r["family"] and r["vf"] >= 5 * median_vf.get(r["drive"], 1.0)]
    lines = [
        f"Recordings: {len(rows)} ({len(rows) - len(ok)} failed to run): {len(lib)} with a library term, "
        f"{len(out)} with physics outside the library, {len(ctrl)} controls.", "",
        "| figure | measured | target |", "|---|---|---|",
        f"| right channel and regressor (alone), library term >= 3x detectable | {pct(sum(r['right'] for r in lib3), len(lib3))} | 90 % |",
        f"| right channel and regressor (alone), library term 1x-3x | {pct(sum(r['right'] for r in lib13), len(lib13))} | - |",
        f"| coefficient within 20 % or 2 sigma (found right) | {pct(sum(r['within'] for r in right), len(right))} | - |",
        f"| held-out heading drift >= 30 % lower (found right) | {pct(sum(r['heldout30'] for r in right), len(right))} | - |",
        f"| no catalogued effect declared, planted physics (all) | {pct(sum(not r['effects'] for r in lib + out), len(lib + out))} | 95 % |",
        f"| physics outside the library not called no_significant_effect | {pct(sum(r['verdict'] != 'no_significant_effect' for r in out), len(out))} | - |",
        f"| controls with a discovered term | {pct(sum(bool(r['discovered']) for r in ctrl), len(ctrl))} | <= 1 % |",
        f"| controls with another verdict than no_significant_effect | {pct(sum(r['verdict'] != 'no_significant_effect' for r in ctrl), len(ctrl))} | - |",
        f"| variance factor >= 5x the drive's median control's and no_significant_effect | "
        f"{sum(r['verdict'] == 'no_significant_effect' for r in far)} of {len(far)} | 0 |", "",
        "Detectable sizes (pilot, seed 900000): " + ", ".join(f"{d} {c} by {g} {v:.3g}" for (d, g, c), v in sorted(det.items())),
        "", "Control variance factors (median per drive): " + ", ".join(f"{d} {v:.3g}" for d, v in sorted(median_vf.items())),
        "", "| drive | seed | planted (channel: regressor = coefficient) | x detectable own (drawn) | verdict | "
        "discovered (± 1σ) | catalogued | variance factor | drift ratio | sensors |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        fam = r["family"]
        planted = f"{fam[0]}: {fam[1]} = {r['coef']:g}{'' if fam[3] else ' (outside)'}" if fam else "control"
        s = r["sensors"]
        sens = (f"fov {math.degrees(s['fov']):.0f} deg, {s['beams']} beams, {s['scan_rate']} Hz, enc {s['enc_rate']} Hz "
                f"{s['ticks']} ticks, noise {100 * s['range_noise']:.1f} cm, step {1000 * s['step']:.1f} ms, "
                f"cmd {s['cmd_rate']} Hz {s['between']}")
        if r["error"]:
            lines.append(f"| {r['drive']} | {r['seed']} | {cell(planted)} | - | error: {r['error']} | | | | | {sens} |")
            continue
        m = f"{r['own_mult']:.1f} ({r['mult']:.1f})" if r.get("own_mult") else (f"({r['mult']:.1f})" if fam else "-")
        disc = "; ".join(f"{c}: {g} = {v:.3g} ± {sd:.2g}" for c, g, v, sd in r["discovered"]) or "-"
        lines.append(f"| {r['drive']} | {r['seed']} | {cell(planted)} | {m} | {r['verdict']} | {cell(disc)} | "
                     f"{', '.join(r['effects']) or '-'} | {r['vf']:.3g} | {r['ratio']:.3g} | {sens} |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="one seed, the largest and smallest size")
    ap.add_argument("--only", choices=["planted", "outside", "controls"], help="one kind of recording")
    ap.add_argument("--random", type=int, default=0, help="randomized mode: recordings per drive")
    ap.add_argument("--first-seed", type=int, default=5000)
    ap.add_argument("--drives", default="diff_robot,forklift")
    ap.add_argument("--controls", type=float, default=0.2, help="randomized mode: share of controls")
    ap.add_argument("--work", help="keep the reports here (and reuse them)")
    ap.add_argument("--out", help="randomized mode: write the figures here (else stdout)")
    ap.add_argument("--no-run", action="store_true", help="randomized mode: score only the reports in --work")
    ap.add_argument("--loop", type=int, default=0, help="randomized mode: sim-to-real loops on this many recordings")
    a = ap.parse_args()
    if a.random:
        a.work = a.work or tempfile.mkdtemp(prefix="discover_suite_")
        os.makedirs(a.work, exist_ok=True)
        with cf.ThreadPoolExecutor(a.jobs) as pool:
            rows, det = random_suite(a, pool)
            text = random_report(a, rows, det) + (sim_loop(a, rows, pool) if a.loop else "")
        if a.out:
            open(a.out, "w").write(text)
        print(text)
        return 0
    seeds = range(101, 101 + (1 if a.quick else a.seeds))
    cases = []
    for sim, channel, regressor, coefs, lib in PLANTED:
        if a.only and a.only != ("planted" if lib else "outside"):
            continue
        for coef in ([coefs[0], coefs[-1]] if a.quick else coefs):
            cases += [(sim, channel, regressor, coef, s) for s in seeds]
    for sim in CONTROLS if a.only in (None, "controls") else []:
        cases += [(sim, "", "", 0, s) for s in range(201, 201 + (2 if a.quick else 2 * a.seeds))]
    in_library = {(c, r) for _, c, r, _, lib in PLANTED if lib}
    work = tempfile.mkdtemp(prefix="discover_suite_")
    print("| sim | planted (channel: regressor = coefficient) | seed | verdict | discovered (± 1σ) | catalogued | "
          "variance factor | heading drift ratio | held-out heading drift before → after |")
    print("|---|---|---|---|---|---|---|---|---|")
    tally = {"right": 0, "planted": 0, "within": 0, "heldout30": 0, "controls": 0, "control_alarms": 0,
             "outside": 0, "outside_not_explained": 0, "catalogued_declared": 0}
    with cf.ThreadPoolExecutor(a.jobs) as pool:
        for (sim, channel, regressor, coef, seed), r in pool.map(lambda c: run(c, work), cases):
            disc = r["discovered"]
            text = "; ".join(f"{d['channel']}: {d['terms'][0]['regressor']} = {d['terms'][0]['coefficient']['value']:.3g}"
                             f" ± {d['terms'][0]['coefficient']['std']:.2g}" for d in disc) or "-"
            drift = "; ".join(f"{d['heldout_drift']['rms_before']:.3g} → {d['heldout_drift']['rms_after']:.3g}"
                              for d in disc) or "-"
            cat = ", ".join(e["name"] for e in r["effects"]) or "-"
            planted = f"{channel}: {regressor} = {coef:g}" if channel else "control"
            m = r["misfit"]
            print(f"| {sim} | {planted} | {seed} | {r['verdict']} | {text} | {cat} | {m['variance_factor']:.3g} | "
                  f"{m['heading_drift_ratio']:.3g} | {drift} |")
            if not channel:
                tally["controls"] += 1
                tally["control_alarms"] += bool(disc) or r["verdict"] != "no_significant_effect"
                continue
            tally["catalogued_declared"] += bool(r["effects"])
            if (channel, regressor) not in in_library:
                tally["outside"] += 1
                tally["outside_not_explained"] += r["verdict"] != "no_significant_effect"
                continue
            tally["planted"] += 1
            hit = [d for d in disc if d["channel"] == channel and d["terms"][0]["regressor"] == regressor]
            if hit:
                tally["right"] += 1
                c = hit[0]["terms"][0]["coefficient"]
                tally["within"] += abs(c["value"] - coef) <= max(0.2 * abs(coef), 2 * c["std"])
                d = hit[0]["heldout_drift"]
                tally["heldout30"] += d["rms_after"] <= 0.7 * d["rms_before"]
    print()
    print(f"- planted library terms: right channel and regressor {tally['right']}/{tally['planted']}, coefficient "
          f"within 20 % or 2σ {tally['within']}/{tally['right']}, held-out heading drift ≥ 30 % lower "
          f"{tally['heldout30']}/{tally['right']}")
    print(f"- physics outside the library: not called explained (verdict ≠ no_significant_effect) "
          f"{tally['outside_not_explained']}/{tally['outside']}")
    print(f"- a catalogued effect declared on a planted recording: {tally['catalogued_declared']}/"
          f"{tally['planted'] + tally['outside']}")
    print(f"- controls with a discovered term or another verdict than no_significant_effect: "
          f"{tally['control_alarms']}/{tally['controls']}")


if __name__ == "__main__":
    sys.exit(main())
