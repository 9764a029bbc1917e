#!/usr/bin/env python3
"""Sigma honesty over the randomized suite's controls (docs/calibration.md, "The lengths' scale bias").

For each drive, the randomized suite's control recordings (scripts/mismatch_suite.py --random: each
seed draws its sensors, world and start; about a third of the seeds plant no effect, and those are
the controls used here), simulated, then `agvcal solve`d with the drive's robot file; per calibrated
value z = (estimate - truth) / reported std, the truth from the drive's config/sims/*.yaml. Prints,
per drive and value, the number of recordings, the mean of z, its spread (standard deviation; 1 if
the reported sigmas are honest) and the largest |z|; exit 1 when a spread is outside --range.

  scripts/sigma_zscores.py [--controls N] [--drives a,b] [--first-seed S] [--jobs J] [--work DIR]
                           [--json ROWS.json] [--reuse [--done-only]] [--range 0.8,1.25]
"""
import argparse
import concurrent.futures as cf
import json
import math
import os
import random
import subprocess
import sys
import tempfile

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mismatch_suite as suite  # noqa: E402  (the randomized suite's draws, reused as they are)

HERE = suite.HERE


def control_seeds(drive, first_seed, count):
    """The first `count` seeds from `first_seed` on that the randomized suite makes controls.

    The suite draws, per seed, the sensors, the world and then whether an effect is planted
    (random_case: none with probability 1/3, decided by its first draw); the same draws here."""
    seeds, seed = [], first_seed
    with tempfile.TemporaryDirectory() as scratch:
        while len(seeds) < count:
            rng = random.Random(f"{drive}-{seed}")
            suite.random_sensors(rng, drive)
            suite.random_world(rng, os.path.join(scratch, "w.world"))
            if rng.random() < 1.0 / 3.0:
                seeds.append(seed)
            seed += 1
    return seeds


def truth_of(drive):
    with open(os.path.join(HERE, "config", "sims", drive + ".yaml")) as f:
        truth = yaml.safe_load(f)["truth"]
    values = {("params", k): v for k, v in truth["params"].items()}
    values.update({("lidar2d", k): v for k, v in truth["lidar2d"].items()})
    return values


def solve_one(args, drive, seed):
    """Simulates the seed's control recording and solves it; the RESULT.json (or an error)."""
    tag = f"{drive}_r{seed}"
    out = os.path.join(args.work, tag + ".result.json")
    if args.reuse and os.path.exists(out):
        with open(out) as f:
            return json.load(f)
    rng = random.Random(f"{drive}-{seed}")
    sensors = suite.random_sensors(rng, drive)
    world = os.path.join(args.work, tag + ".world")
    suite.random_world(rng, world)
    sim = os.path.join(args.work, tag + ".yaml")
    log = os.path.join(args.work, tag + ".log")
    with open(sim, "w") as f:
        f.write(suite.random_sim_text(drive, seed, sensors, world, []))
    agvcal = os.path.join(args.build, "agvcal")
    r = subprocess.run([agvcal, "simulate", sim, log, "--quiet"], stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        return {"error": f"simulate exit {r.returncode}: {r.stderr.strip()[:200]}"}
    robot = os.path.join(HERE, "config", "robots", suite.drive_robot(drive))
    r = subprocess.run([agvcal, "solve", robot, log, "--out", out], stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, text=True)
    os.remove(log)
    if r.returncode != 0:
        return {"error": f"solve exit {r.returncode}: {r.stderr.strip()[:200]}"}
    with open(out) as f:
        return json.load(f)


def z_scores(result, truth):
    return {f"{group}.{name}" if group == "lidar2d" else name:
            (result[group][name]["value"] - value) / result[group][name]["std"]
            for (group, name), value in truth.items()
            if result.get(group, {}).get(name, {}).get("std")}


def table(rows, drives, spread_range):
    lines = ["| drive | value | recordings | mean z | spread of z | largest abs z | within range |",
             "|---|---|---|---|---|---|---|"]
    outside = 0
    for d in drives:
        zs = {}
        for row in rows:
            if row["drive"] == d and "z" in row:
                for k, z in row["z"].items():
                    zs.setdefault(k, []).append(z)
        for k, v in zs.items():
            n = len(v)
            mean = sum(v) / n
            spread = math.sqrt(sum((z - mean) ** 2 for z in v) / (n - 1)) if n > 1 else float("nan")
            ok = spread_range[0] <= spread <= spread_range[1]
            outside += not ok
            lines.append(f"| {d} | {k} | {n} | {mean:+.2f} | {spread:.2f} | {max(abs(z) for z in v):.1f} | "
                         f"{'yes' if ok else '**no**'} |")
    return "\n".join(lines), outside


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("AGVCAL_BIN", os.path.join(HERE, "build")))
    ap.add_argument("--controls", type=int, default=34, help="control recordings per drive")
    ap.add_argument("--drives", default=",".join(suite.DRIVES))
    ap.add_argument("--first-seed", type=int, default=1, help="the randomized suite's first seed")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--work", default="")
    ap.add_argument("--json", default="", help="write the rows (drive, seed, z per value) here")
    ap.add_argument("--reuse", action="store_true", help="reuse the RESULT.json files already in --work")
    ap.add_argument("--done-only", action="store_true",
                    help="with --reuse: tabulate the RESULT.json files in --work, run nothing new")
    ap.add_argument("--range", default="0.8,1.25", help="the spread of z every value must be within")
    args = ap.parse_args()
    if args.done_only and not (args.reuse and args.work):
        ap.error("--done-only needs --reuse and --work")
    args.work = args.work or tempfile.mkdtemp(prefix="sigma-zscores-")
    os.makedirs(args.work, exist_ok=True)
    drives = args.drives.split(",")
    spread_range = [float(x) for x in args.range.split(",")]
    pool = cf.ThreadPoolExecutor(max_workers=args.jobs)
    # Round robin over the drives, so a run stopped early has covered each drive alike.
    seeds = {d: control_seeds(d, args.first_seed, args.controls) for d in drives}
    jobs = {}
    for k in range(args.controls):
        for d in drives:
            if args.done_only and not os.path.exists(os.path.join(args.work, f"{d}_r{seeds[d][k]}.result.json")):
                continue
            jobs[pool.submit(solve_one, args, d, seeds[d][k])] = (d, seeds[d][k])
    rows = []
    for fut in cf.as_completed(jobs):
        d, seed = jobs[fut]
        result = fut.result()
        row = {"drive": d, "seed": seed}
        if "error" in result:
            row["error"] = result["error"]
        else:
            row["z"] = z_scores(result, truth_of(d))
        rows.append(row)
        print(f"{d} seed {seed}: {row.get('error') or ' '.join(f'{k} {z:+.2f}' for k, z in row['z'].items())}",
              file=sys.stderr, flush=True)
    rows.sort(key=lambda r: (r["drive"], r["seed"]))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    text, outside = table(rows, drives, spread_range)
    failed = [r for r in rows if "error" in r]
    print(f"Controls: {len(rows)} ({len(failed)} failed to solve), seeds from {args.first_seed}; "
          f"z = (estimate - truth) / reported std.\n")
    print(text)
    for r in failed:
        print(f"- {r['drive']} seed {r['seed']}: {r['error']}")
    return 1 if outside else 0


if __name__ == "__main__":
    sys.exit(main())
