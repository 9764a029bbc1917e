#!/usr/bin/env python3
"""Concealed-effect suite for `agvcal diagnose` (docs/mismatch.md).

For every drive type: simulated recordings in which one effect of spec/effects.md (or a
confusable pair) is present but declared nowhere, at twice the smallest magnitude the
diagnosis can detect on that drive's trajectory (taken from the no-effect controls'
REPORT.json `detectable`), plus controls: no effect (plain, and with coloured encoder noise
and scan-matching outliers) and an effect the trajectory does not excite. Every recording
is diagnosed blind; the script then compares with the truth and writes the confusion table.

Each seed also starts the route somewhere else in the warehouse's open area (within 1.5 m of
the origin, any heading; `start_pose`), so the seeds are independent draws of the scan
matcher's place-dependent error too, not only of the lidar noise on one route.

  scripts/mismatch-suite.sh [--seeds N] [--jobs J] [--out docs/mismatch-suite.md] [--quick]

Randomized mode (--random N, docs/mismatch-suite.md "Randomized suite"): N recordings per drive
(about a third of them controls), each drawing its sensors at random (lidar field of view
180-360 deg, 270-1080 beams, 10-40 Hz scans, encoders 50-200 Hz with 1024-16384 ticks, range
noise 0.5-3 cm, physics step 1-10 ms, commands 10-50 Hz held, ramped or samples of a continuous
setpoint), its world (the warehouse with racks removed and boxes added at random), its start,
one concealed effect at
1x-20x the drive's detectable size (time offsets 1 ms - 0.5 s), all from the recording's seed;
then the issue's targets are scored (right name at >= 2x and at 1-2x, controls clean, size
within 15 % or 2 sigma, judged held-out measure >= 30 % lower).

  scripts/mismatch-suite.sh --random 140 [--jobs J] [--out docs/mismatch-random.md] [--first-seed S]
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

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

DRIVES = {
    "diff_robot": {"wheel": "left", "steered": False},
    "forklift": {"wheel": "drive", "steered": True},
    "dual_steer_agv": {"wheel": "a1", "steered": True},
}
# effect -> (parameter key, how the magnitude is set)
EFFECTS = {
    "time_offset": "offset_s",
    "longitudinal_slip": "slip_per_accel",
    "lateral_slip": "gain",
    "wheel_eccentricity": "amplitude",
    "steering_backlash": "width_rad",
    "scan_distortion": "scan_period_s",
    "drive_lag": "tau_s",
    "steering_rate_limit": "rate_rad_s",
}
STEERED_ONLY = {"steering_backlash", "steering_rate_limit", "steering_lag"}


def round2(x):
    if x == 0:
        return 0.0
    d = math.floor(math.log10(abs(x)))
    return round(x, 1 - d)


def effect_yaml(name, value, wheel):
    key = EFFECTS.get(name, "tau_s")
    if name == "wheel_eccentricity":
        return f"{name}: {{amplitude: {value}, phase: 0.4, wheel: {wheel}}}"
    return f"{name}: {{{key}: {value}}}"


def start_pose(seed):
    """The seed's start: within 1.5 m of the origin, any heading (config/worlds/warehouse.world
    keeps x -10..10, y -9..9 free; the routes stay within 7 m of their start)."""
    rng = random.Random(seed)
    r, a = 1.5 * math.sqrt(rng.random()), rng.uniform(-math.pi, math.pi)
    return f"start: {{x: {r * math.cos(a):.3f}, y: {r * math.sin(a):.3f}, theta: {rng.uniform(-math.pi, math.pi):.3f}}}"


def seeded_line(line, seed):
    """A top-level line of a drive's sim config for one seed: the robot file by absolute path,
    the seed, the seed's start."""
    if line.startswith("robot: ../robots/"):
        return "robot: " + os.path.join(HERE, "config", "robots", line.split("/")[-1])
    if line.startswith("seed:"):
        return f"seed: {seed}"
    if line.startswith("start:"):
        return start_pose(seed)
    return line


def run_one(args, drive, scenario, effects, seed, extra_sensors=None, trajectory="default"):
    """Simulates and diagnoses one recording; returns the parsed REPORT.json (or an error)."""
    tag = f"{drive}_{scenario}_{seed}"
    with open(os.path.join(HERE, "config", "sims", drive + ".yaml")) as f:
        text = f.read()
    lines = []
    section = ""
    for line in text.splitlines():
        if line and not line.startswith(" "):
            section = line.split(":")[0]
        line = seeded_line(line, seed)
        for replacement in extra_sensors or []:
            if section == "sensors" and line.strip().startswith(replacement.split(":")[0] + ":"):
                line = "  " + replacement
        lines.append(line)
    if effects:
        lines.append("effects:")
        lines += ["  " + e for e in effects]
    return simulate_and_diagnose(args, tag, "\n".join(lines) + "\n", drive, trajectory)


def simulate_and_diagnose(args, tag, sim_text, drive, trajectory="default"):
    """Writes the sim config, simulates, diagnoses blind; the parsed REPORT.json or an error."""
    sim = os.path.join(args.work, tag + ".yaml")
    log = os.path.join(args.work, tag + ".log")
    out = os.path.join(args.work, tag + ".json")
    if args.reuse and os.path.exists(out):
        with open(out) as f:
            return json.load(f)
    with open(sim, "w") as f:
        f.write(sim_text)
    agvcal = os.path.join(args.build, "agvcal")
    r = subprocess.run([agvcal, "simulate", sim, log, "--trajectory", trajectory, "--quiet"],
                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        return {"error": f"simulate exit {r.returncode}: {r.stderr.strip()[:200]}"}
    robot = os.path.join(HERE, "config", "robots", drive_robot(drive))
    r = subprocess.run([agvcal, "diagnose", robot, log, "--out", out, "--quiet"], stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, text=True)
    os.remove(log)
    if r.returncode != 0:
        return {"error": f"exit {r.returncode}: {r.stderr.strip()[:200]}"}
    with open(out) as f:
        rep = json.load(f)
    rep.pop("intervals", None)
    with open(out, "w") as f:
        json.dump(rep, f)
    return rep


def random_world(rng, path):
    """The warehouse with each rack, machine and pillar kept with probability 0.7 and 3-10 boxes
    added at random outside the free open area (x -10..10, y -9..9) and inside the hall."""
    lines = []
    with open(os.path.join(HERE, "config", "worlds", "warehouse.world")) as f:
        for line in f:
            if line.split()[:1] in (["box"], ["pillar"]) and rng.random() > 0.7:
                continue
            lines.append(line.rstrip("\n"))
    for _ in range(rng.randint(3, 10)):
        w, h = rng.uniform(0.4, 4.0), rng.uniform(0.4, 4.0)
        while True:
            x, y = rng.uniform(-21, 21 - w), rng.uniform(-16.5, 16.5 - h)
            if x > 10.5 or x + w < -10.5 or y > 9.5 or y + h < -9.5:
                break
        lines.append(f"box {x:.2f} {y:.2f} {x + w:.2f} {y + h:.2f} {rng.uniform(1, 6):.1f}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def random_sensors(rng, drive):
    """One recording's sensors, physics step and command profile (the ranges of issue 16)."""
    enc = rng.uniform(50, 200)
    scan = rng.uniform(10, 40)
    # A sensor samples at most once per physics step: the step stays within the encoder period.
    step = math.floor(min(rng.uniform(0.001, 0.010), 1.0 / enc) * 1e4) / 1e4
    fov = math.radians(rng.uniform(180, 360))
    d = {"enc_rate": round(enc, 1), "ticks": rng.randint(1024, 16384), "scan_rate": round(scan, 1),
         "fov": round(fov, 4), "beams": rng.randint(270, 1080), "range_noise": round(rng.uniform(0.005, 0.03), 4),
         "step": step, "cmd_rate": round(rng.uniform(10, 50), 1),
         "between": rng.choice(["hold", "ramp", "continuous"])}
    d["cmd_rate"] = min(d["cmd_rate"], round(1.0 / d["step"], 1))
    d["enc_rate"] = min(d["enc_rate"], math.floor(10.0 / d["step"]) / 10)  # rounding took 188.68 Hz to 188.7
    return d


def random_sim_text(drive, seed, sensors, world_path, effects):
    phys = 1.0 / sensors["step"]
    with open(os.path.join(HERE, "config", "sims", drive + ".yaml")) as f:
        text = f.read()
    out, section = [], ""
    for line in text.splitlines():
        if line and not line.startswith(" "):
            section = line.split(":")[0]
        if section == "sensors" or line.startswith("#"):
            continue
        out.append(f"world: {world_path}" if line.startswith("world:") else seeded_line(line, seed))
    steer = ", steer_resolution: 0.0002, steer_noise: 0.0002" if DRIVES[drive]["steered"] else ""
    out += [f"physics_step: {sensors['step']}",
            f"commands: {{rate: {sensors['cmd_rate']}, between: {sensors['between']}}}",
            "sensors:",
            f"  wheels: {{rate: {sensors['enc_rate']}, ticks_per_rev: {sensors['ticks']}{steer}}}",
            f"  lidar2d: {{rate: {sensors['scan_rate']}, beams: {sensors['beams']}, fov: {sensors['fov']}, "
            f"range_noise: {sensors['range_noise']}}}",
            f"  imu: {{rate: {min(200.0, math.floor(phys * 10) / 10)}}}",
            f"  ground_truth: {{rate: {min(100.0, math.floor(phys * 10) / 10)}}}"]
    if effects:
        out.append("effects:")
        out += ["  " + e for e in effects]
    return "\n".join(out) + "\n"


def drive_robot(drive):
    with open(os.path.join(HERE, "config", "sims", drive + ".yaml")) as f:
        for line in f:
            if line.startswith("robot:"):
                return line.split("/")[-1].strip()
    raise SystemExit(f"{drive}: no robot in the sim config")


def named(rep):
    return sorted(e["name"] for e in rep.get("effects", []))


# Effects of the randomized suite per drive (time_offset drawn 1 ms - 0.5 s, the rest 1x-20x
# the drive's detectable size from its controls; steering_rate_limit: 1 rad/s / multiplier;
# scan_distortion: the real sweep of the drawn field of view at the drawn scan rate).
RANDOM_EFFECTS = ["time_offset", "longitudinal_slip", "lateral_slip", "wheel_eccentricity", "steering_backlash",
                  "scan_distortion", "drive_lag", "steering_rate_limit"]


def random_case(rng, drive, mde, sensors):
    """The concealed effect of one recording: (name, value, multiplier) or None for a control."""
    names = [n for n in RANDOM_EFFECTS if DRIVES[drive]["steered"] or n not in STEERED_ONLY]
    if rng.random() < 1.0 / 3.0:
        return None
    name = rng.choice(names)
    mult = math.exp(rng.uniform(0, math.log(20)))
    if name == "time_offset":
        value = round2(math.exp(rng.uniform(math.log(0.001), math.log(0.5))))
        mult = value / mde.get((drive, name), 0.0005)
    elif name == "scan_distortion":
        value = math.floor(sensors["fov"] / (2 * math.pi) / sensors["scan_rate"] * 1e4) / 1e4  # <= 1 / rate
        mult = value / mde.get((drive, name), 0.01)
    elif name == "steering_rate_limit":
        value = round2(1.0 / mult)
    elif name == "drive_lag":
        value = round2(min(mult * mde.get((drive, name), 0.01), 0.3))
    else:
        if (drive, name) not in mde:
            return None
        value = round2(mult * mde[(drive, name)])
    return name, value, mult


def score_effect(e, truth):
    """Size within 15 % or 2 sigma; the judged held-out measure's reduction (None if absent)."""
    est = e["params"][EFFECTS[e["name"]]]
    tv = truth[e["name"]]
    size_ok = abs(est["value"] - tv) <= 0.15 * abs(tv) or (est["std"] and abs(est["value"] - tv) <= 2 * est["std"])
    b, a = e["heldout_rms_before"], e["heldout_rms_after"]
    if e.get("heldout_measure") == "drift" and e.get("heldout_drift", {}).get("rms_before"):
        b, a = e["heldout_drift"]["rms_before"], e["heldout_drift"]["rms_after"]
    elif e.get("heldout_measure") == "stretch" and e.get("heldout_stretch", {}).get("rms_before"):
        b, a = e["heldout_stretch"]["rms_before"], e["heldout_stretch"]["rms_after"]
    return size_ok, (1 - a / b) if b else None


def own_multiplier(rep, case):
    """The effect's size over the detectable size this recording's own REPORT.json states for it.

    The drive's median (the drawn multiplier) stands for recordings whose sensors were drawn
    differently; the recording's own figure is the tool's claim for those very sensors. A steering
    rate limit shows the more the lower it is: its `detectable` is the highest rate the recording
    can tell from the commands' own ramp, so its multiplier is that rate over the true one."""
    if not case:
        return None
    det = next((c.get("detectable") for c in rep.get("candidates", []) if c["name"] == case[0]), None)
    if not det or not math.isfinite(det):
        return case[2]
    return det / abs(case[1]) if case[0] == "steering_rate_limit" else abs(case[1]) / det


def random_suite(args, drives, pool):
    """The randomized suite (--random N): see the module's doc string."""
    per_drive = args.random
    # 1. Detectable sizes: from controls with random sensors (seeds first_seed + 0 ..).
    cases = []
    for d in drives:
        for k in range(per_drive):
            cases.append((d, args.first_seed + k))
    def one(d, seed):
        rng = random.Random(f"{d}-{seed}")
        sensors = random_sensors(rng, d)
        world = os.path.join(args.work, f"{d}_r{seed}.world")
        random_world(rng, world)
        return rng, sensors, world
    mde = {}
    calib_jobs = {}
    for d in drives:  # a few controls per drive fix the detectable sizes first
        for k in range(max(3, min(8, per_drive // 6))):
            seed = args.first_seed + 100000 + k
            rng, sensors, world = one(d, seed)
            text = random_sim_text(d, seed, sensors, world, [])
            calib_jobs[pool.submit(simulate_and_diagnose, args, f"{d}_rcal_{seed}", text, d)] = d
    det = {}
    for fut in cf.as_completed(calib_jobs):
        d = calib_jobs[fut]
        for c in fut.result().get("candidates", []):
            if c["name"] in EFFECTS and c.get("detectable"):
                det.setdefault((d, c["name"]), []).append(c["detectable"])
    mde = {k: sorted(v)[len(v) // 2] for k, v in det.items()}
    jobs = {}
    for d, seed in cases:
        rng, sensors, world = one(d, seed)
        case = random_case(rng, d, mde, sensors)
        effects, truth = [], {}
        if case:
            name, value, mult = case
            effects = [effect_yaml(name, value, DRIVES[d]["wheel"])]
            truth = {name: value}
        text = random_sim_text(d, seed, sensors, world, effects)
        jobs[pool.submit(simulate_and_diagnose, args, f"{d}_r{seed}", text, d)] = (d, seed, sensors, case, truth)
    rows = []
    for fut in cf.as_completed(jobs):
        d, seed, sensors, case, truth = jobs[fut]
        rep = fut.result()
        row = {"drive": d, "seed": seed, "sensors": sensors, "truth": truth,
               "multiplier": case[2] if case else None, "error": rep.get("error")}
        if "error" not in rep:
            found = named(rep)
            row["named"] = found
            row["right"] = found == sorted(truth)
            for e in rep.get("effects", []):
                if e["name"] in truth:
                    row["size_ok"], row["heldout_reduction"] = score_effect(e, truth)
                    row["estimate"] = e["params"][EFFECTS[e["name"]]]
            row["own_multiplier"] = own_multiplier(rep, case)
        rows.append(row)
    return sorted(rows, key=lambda r: (r["drive"], r["seed"])), mde


def random_report(args, rows, mde):
    pct = lambda a, b: f"{100.0 * a / b:.1f} % ({a}/{b})" if b else "-"
    ok = [r for r in rows if not r["error"]]
    controls = [r for r in ok if not r["truth"]]
    own = lambda r: r.get("own_multiplier") or r["multiplier"]
    at2 = [r for r in ok if r["truth"] and own(r) >= 2]
    at1 = [r for r in ok if r["truth"] and 1 <= own(r) < 2]
    below = [r for r in ok if r["truth"] and own(r) < 1]
    drawn2 = [r for r in ok if r["truth"] and r["multiplier"] >= 2]
    drawn1 = [r for r in ok if r["truth"] and r["multiplier"] < 2]
    named_right = [r for r in ok if r["truth"] and r["right"]]
    size = [r for r in named_right if "size_ok" in r]
    held = [r for r in named_right if r.get("heldout_reduction") is not None]
    figures = [
        ("right name, effect >= 2x detectable", sum(r["right"] for r in at2), len(at2), 0.95),
        ("right name, effect 1x-2x detectable", sum(r["right"] for r in at1), len(at1), 0.80),
        ("no effect declared on controls", sum(r["right"] for r in controls), len(controls), 0.99),
        ("size within 15 % or 2 sigma (named right)", sum(r["size_ok"] for r in size), len(size), 0.90),
        ("judged held-out measure >= 30 % lower (named right)", sum(r["heldout_reduction"] >= 0.3 for r in held),
         len(held), 0.90),
    ]
    lines = ["# Randomized concealed-effect suite", "",
             "Generated by `scripts/mismatch-suite.sh " + " ".join(sys.argv[1:]) + "`: every recording draws its",
             "sensors, physics step, command profile, world, start and concealed effect from its seed",
             "(scripts/mismatch_suite.py `random_sensors`, `random_world`, `random_case`).", "",
             f"Recordings: {len(rows)} ({len(rows) - len(ok)} failed to run), controls {len(controls)}.", "",
             "| figure | measured | target | met |", "|---|---|---|---|"]
    for label, a, b, target in figures:
        met = "yes" if b and a / b >= target else ("-" if not b else "no")
        lines.append(f"| {label} | {pct(a, b)} | {100 * target:.0f} % | {met} |")
    lines += ["", "Multipliers are the true size over the detectable size the recording's own REPORT.json",
              "states for that effect (its sensors and route set it). Against the drive's median detectable",
              "size from the random controls instead (the size the effect was drawn with):",
              f"right name >= 2x {pct(sum(r['right'] for r in drawn2), len(drawn2))}, "
              f"1x-2x {pct(sum(r['right'] for r in drawn1), len(drawn1))}; "
              f"below 1x of its own detectable size (not scored): {pct(sum(r['right'] for r in below), len(below))} named."]
    lines += ["", "Detectable sizes (median over the random controls used to set the sizes): " +
              ", ".join(f"{d} {n} {v:.3g}" for (d, n), v in sorted(mde.items())), "",
              "| drive | seed | truth | x detectable own (drawn) | named | estimate | held-out reduction | sensors |",
              "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        truth = ", ".join(f"{k} {v:g}" for k, v in r["truth"].items()) or "none"
        est = r.get("estimate")
        s = r["sensors"]
        sens = (f"fov {math.degrees(s['fov']):.0f} deg, {s['beams']} beams, {s['scan_rate']} Hz, enc {s['enc_rate']} Hz "
                f"{s['ticks']} ticks, noise {100 * s['range_noise']:.1f} cm, step {1000 * s['step']:.1f} ms, "
                f"cmd {s['cmd_rate']} Hz {s['between']}")
        lines.append(f"| {r['drive']} | {r['seed']} | {truth} | "
                     f"{'-' if r['multiplier'] is None else format(own(r), '.1f') + ' (' + format(r['multiplier'], '.1f') + ')'} | "
                     f"{r['error'][:60] if r['error'] else (', '.join(r.get('named', [])) or 'nothing')} | "
                     f"{'-' if not est else format(est['value'], '.3g') + ' ± ' + format(est['std'], '.2g')} | "
                     f"{'-' if r.get('heldout_reduction') is None else format(100 * r['heldout_reduction'], '.0f') + ' %'} | "
                     f"{sens} |")
    return "\n".join(lines) + "\n"


def write_outputs(args, text, rows):
    """The Markdown report to --out, the rows to --json, the report to stdout."""
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    print(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("AGVCAL_BIN", os.path.join(HERE, "build")))
    ap.add_argument("--seeds", type=int, default=10, help="recordings per scenario")
    ap.add_argument("--controls", type=int, default=0, help="recordings per control (default 2x seeds)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default="", help="write the Markdown report here")
    ap.add_argument("--work", default="")
    ap.add_argument("--json", default="", help="write the rows as JSON here (for tests)")
    ap.add_argument("--reuse", action="store_true", help="reuse the REPORT.json already in --work")
    ap.add_argument("--quick", action="store_true", help="CI size: forklift and diff drive, few scenarios")
    ap.add_argument("--drives", default=",".join(DRIVES))
    ap.add_argument("--random", type=int, default=0, help="randomized suite: recordings per drive")
    ap.add_argument("--first-seed", type=int, default=1, help="randomized suite: seed of the first recording")
    args = ap.parse_args()
    args.work = args.work or tempfile.mkdtemp(prefix="mismatch-suite-")
    os.makedirs(args.work, exist_ok=True)
    controls = args.controls or 2 * args.seeds
    drives = args.drives.split(",")
    if args.quick:
        drives = [d for d in drives if d in ("forklift", "diff_robot")]
    pool = cf.ThreadPoolExecutor(max_workers=args.jobs)
    if args.random:
        rows, mde = random_suite(args, drives, pool)
        write_outputs(args, random_report(args, rows, mde), rows)
        return

    # 1. Controls without any effect: false alarms, and the detectable sizes.
    jobs = {}
    for d in drives:
        for s in range(controls):
            jobs[pool.submit(run_one, args, d, "none", [], 1000 + s)] = (d, "none", None)
            # Coloured noise: encoder angle noise makes consecutive increments anti-correlated
            # (MA(1)); beam dropouts and coarser ranges spread the scan-matching errors.
            noisy = ["wheels: {rate: 100, ticks_per_rev: 4096, tick_noise: 0.5}",
                     "lidar2d: {rate: 20, beams: 720, range_noise: 0.03, dropout: 0.3}"]
            jobs[pool.submit(run_one, args, d, "noisy", [], 2000 + s, noisy)] = (d, "noisy", None)
    results = {}
    for fut in cf.as_completed(jobs):
        d, sc, _ = jobs[fut]
        results.setdefault((d, sc, None), []).append(fut.result())
    detectable = {}
    for d in drives:
        for rep in results[(d, "none", None)]:
            for c in rep.get("candidates", []):
                if c["name"] in EFFECTS and c.get("detectable"):
                    detectable.setdefault((d, c["name"]), []).append(c["detectable"])
    mde = {k: sorted(v)[len(v) // 2] for k, v in detectable.items()}

    # 2. One concealed effect at twice its detectable size; a confusable pair; an unexcited effect.
    scenarios = []
    for d in drives:
        for name in EFFECTS:
            if name in STEERED_ONLY and not DRIVES[d]["steered"]:
                continue
            if name == "scan_distortion":
                value = 0.05  # the scan really takes one 20 Hz period; nothing smaller exists
            elif name == "steering_rate_limit":
                value = 0.5   # half the commanded steering rate
            elif name == "drive_lag":
                value = 0.02  # its statistical limit is far smaller; a 5 % held-out floor sets it
            else:
                if (d, name) not in mde:
                    continue
                value = round2(2 * mde[(d, name)])
            if args.quick and name not in ("time_offset", "longitudinal_slip", "steering_backlash", "drive_lag"):
                continue
            scenarios.append((d, name, [effect_yaml(name, value, DRIVES[d]["wheel"])], {name: value}, "default"))
        if not args.quick:
            to, sl = round2(2 * mde.get((d, "time_offset"), 0.001)), round2(2 * mde.get((d, "longitudinal_slip"), 0.002))
            scenarios.append((d, "time_offset+longitudinal_slip",
                              [effect_yaml("time_offset", to, ""), effect_yaml("longitudinal_slip", sl, "")],
                              {"time_offset": to, "longitudinal_slip": sl}, "default"))
        # Not excited: steering lag (steering turns only at standstill), lateral slip on UMBmark
        # (straights and turns in place: v * omega = 0).
        if DRIVES[d]["steered"]:
            scenarios.append((d, "unexcited:steering_lag", ["steering_lag: {tau_s: 0.1}"], {}, "default"))
        else:
            scenarios.append((d, "unexcited:lateral_slip", ["lateral_slip: {gain: 0.05}"], {}, "umbmark"))
    jobs = {}
    for d, sc, fx, truth, traj in scenarios:
        for s in range(args.seeds):
            jobs[pool.submit(run_one, args, d, sc.replace(":", "_").replace("+", "_"), fx, 3000 + s, None, traj)] = (d, sc, json.dumps(truth))
    for fut in cf.as_completed(jobs):
        d, sc, truth = jobs[fut]
        results.setdefault((d, sc, truth), []).append(fut.result())

    # 3. Scores and the confusion table.
    catalogue = list(EFFECTS) + ["steering_lag"]
    lines = ["# Concealed-effect suite: confusion table", "",
             "Generated by `scripts/mismatch-suite.sh " + " ".join(sys.argv[1:]) + "`; every recording is a",
             "simulator run with the effect present but declared nowhere, diagnosed blind by `agvcal diagnose`.",
             "Magnitudes are twice the median `detectable` size of the drive's no-effect controls",
             "(scan_distortion: a real 50 ms scan; steering_rate_limit: half the commanded steering rate;",
             "drive_lag: 20 ms, a fifth of a typical drive's response time).",
             "The held-out measure (REPORT.json `heldout_measure`): dead-reckoning drift over 2 s windows of",
             "held-out motion for effects whose error adds up along the way (lateral slip, backlash, scan",
             "distortion); the error chained over the stretch of each held-out block where the effect acts",
             "most for those whose chained error telescopes to the stretch's ends (time offset, longitudinal",
             "slip); the residual per interval where the effect acts for wheel eccentricity (it cancels over",
             "a revolution) and those not chained (the actuation effects).", "",
             "| drive | truth | size | runs | named correctly | other effect named | of which reported indistinguishable from the truth | parameter within 20 % or 2σ | held-out error ≥ 20 % lower (its measure) | median reduction: drift over 2 s | median reduction: stretch where it acts most | median reduction: per interval where it acts |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    confusion = ["", "## What was named", "",
                 "| drive | truth | " + " | ".join(catalogue) + " | nothing | errors |",
                 "|---|---|" + "---|" * (len(catalogue) + 2)]
    ordered = sorted(results, key=lambda k: (k[0], k[1] not in ("none", "noisy"), k[1]))
    rows = []
    for key in ordered:
        d, sc, truth = key
        reps = results[key]
        truth = json.loads(truth) if truth else {}
        ok = other = param_ok = rms_ok = ambiguous = 0
        reductions, drift_reductions, stretch_reductions, interval_reductions = [], [], [], []
        counts = {c: 0 for c in catalogue}
        nothing = errors = 0
        for rep in reps:
            if "error" in rep:
                errors += 1
                continue
            found = named(rep)
            for f in found:
                counts[f] = counts.get(f, 0) + 1
            nothing += not found
            expected = sorted(truth)
            if expected:
                ok += found == expected
            else:
                ok += not found
            other += any(f not in truth for f in found)
            pairs = [set(d["effects"]) for d in rep.get("indistinguishable", [])]
            ambiguous += any(p & set(truth) for p in pairs) and found != expected
            for e in rep.get("effects", []):
                if e["name"] not in truth:
                    continue
                key_ = EFFECTS[e["name"]]
                est = e["params"][key_]
                tv = truth[e["name"]]
                if abs(est["value"] - tv) <= 0.2 * abs(tv) or (est["std"] and abs(est["value"] - tv) <= 2 * est["std"]):
                    param_ok += 1
                b, a = e["heldout_rms_before"], e["heldout_rms_after"]
                if b and b > 0:
                    interval_reductions.append(1 - a / b)
                drift = e.get("heldout_drift", {})
                if drift.get("rms_before"):
                    drift_reductions.append(1 - drift["rms_after"] / drift["rms_before"])
                stretch = e.get("heldout_stretch", {})
                if stretch.get("rms_before"):
                    stretch_reductions.append(1 - stretch["rms_after"] / stretch["rms_before"])
                if e.get("heldout_measure") == "drift" and drift.get("rms_before"):
                    b, a = drift["rms_before"], drift["rms_after"]
                elif e.get("heldout_measure") == "stretch" and stretch.get("rms_before"):
                    b, a = stretch["rms_before"], stretch["rms_after"]
                if b and b > 0:
                    reductions.append(1 - a / b)
                    rms_ok += (1 - a / b) >= 0.2
        n = len(reps) - errors
        n_eff = max(1, sum(1 for rep in reps if "error" not in rep) * max(1, len(truth)))
        size = ", ".join(f"{k.split('_')[0]} {v:g}" for k, v in truth.items()) or "-"
        label = sc if truth or sc.startswith("unexcited") else ("none" if sc == "none" else "none, coloured noise + outliers")
        median = lambda xs: f"{100 * sorted(xs)[len(xs) // 2]:.0f} %" if xs else "-"
        pct = lambda x, m: f"{100.0 * x / m:.0f} %" if m else "-"
        lines.append(f"| {d} | {label} | {size} | {n} | {pct(ok, n)} | {pct(other, n)} | {pct(ambiguous, n) if truth else '-'} | "
                     f"{pct(param_ok, n_eff) if truth else '-'} | {pct(rms_ok, n_eff) if truth else '-'} | "
                     f"{median(drift_reductions)} | {median(stretch_reductions)} | {median(interval_reductions)} |")
        rows.append({"drive": d, "truth": sc, "runs": n, "named_correctly": ok, "other_named": other, "ambiguous": ambiguous,
                     "param_ok": param_ok, "rms_ok": rms_ok, "errors": errors, "named": counts})
        confusion.append(f"| {d} | {label} | " + " | ".join(str(counts.get(c, 0)) for c in catalogue) +
                         f" | {nothing} | {errors} |")
    text = "\n".join(lines + confusion) + "\n"
    text += f"\nWork folder (REPORT.json of every run): `{args.work}`.\n" if not args.out else ""
    write_outputs(args, text, rows)
    # Exit status for CI: every named effect right on the quick set.
    if args.quick:
        bad = [k for k in ordered if any("error" in r for r in results[k])]
        sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
