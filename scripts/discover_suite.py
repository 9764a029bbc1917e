#!/usr/bin/env python3
"""Physics outside the catalogue (docs/effects.md "Discovered physics"): simulated recordings with
a planted term (sim config `terms:`) at several sizes, physics the library has no term for, and
controls, each diagnosed blind; prints a Markdown table (truth against what was discovered, the
verdict, the misfit) and the tallies.

  scripts/discover_suite.py [--seeds N] [--jobs J] [--quick] [--only planted|outside|controls]
"""
import argparse
import concurrent.futures as cf
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
AGVCAL = os.path.join(os.environ.get("AGVCAL_BIN", os.path.join(HERE, "build")), "agvcal")

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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="one seed, the largest and smallest size")
    ap.add_argument("--only", choices=["planted", "outside", "controls"], help="one kind of recording")
    a = ap.parse_args()
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
