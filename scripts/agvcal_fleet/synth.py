"""`agvcal-fleet synth`: a synthetic fleet made with the simulator, for the tests and the
benchmark (docs/fleet.md).

Every robot has its own true parameters (the nominal robot file's, perturbed) and is
recorded on M days spread over the span (`agvcal simulate ... --trajectory demo`, about 25 s
each, the recording's start time set by the simulation config's `start_utime`, a new seed
and start pose every time). Scenarios, by robot:
  constant  the truth never changes
  drift     one parameter moves linearly over the whole span: tire wear (a radius shrinks
            0.4-0.8 %) or a loosening lidar mount (its yaw turns 0.3-0.6 deg)
  step      a sudden change on a day within the middle 40 % of the span: a knocked lidar
            (yaw 0.3-0.6 deg and x 3-8 mm), a replaced tire (radius +0.5-1 %, differential)
            or a slipped steering encoder (steer_offset 0.1-0.3 deg, forklift)
  effect    from one day on (the same day for every such robot: a firmware update) the
            lidar's scans carry a latency (`effects: time_offset`, 2.5 ms)
The truth goes to truth.json (only the tests and the benchmark's scoring read it), the
fleet to fleet.yaml, robot files to robots/, simulation configs to sims/, recordings to
logs/ID/ID_DATE_K.log.
"""
import concurrent.futures as cf
import datetime
import json
import math
import os
import random
import subprocess

from .errors import UsageError

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EPOCH = datetime.datetime(2025, 1, 6, tzinfo=datetime.timezone.utc)  # day 0 of the fleet

DRIVES = {
    "diff": {"robot": "diff_robot.yaml", "radii": ["left_radius", "right_radius"],
             "lengths": ["track"],
             "sensors": "  wheels: {rate: 100, ticks_per_rev: 4096}\n"},
    "forklift": {"robot": "forklift.yaml", "radii": ["drive_radius"], "lengths": ["wheelbase"],
                 "sensors": "  wheels: {rate: 100, ticks_per_rev: 4096, steer_resolution: 0.0002, "
                            "steer_noise: 0.0002}\n"},
}
SCENARIOS = ("constant", "drift", "step", "effect")
EFFECT_OFFSET_S = 0.0025


def parse_plan(text):
    """'constant,drift@forklift,step,effect' -> [(scenario, drive or None), ...]"""
    out = []
    for item in text.split(","):
        scen, _, drive = item.strip().partition("@")
        if scen not in SCENARIOS:
            raise UsageError(f"--plan: unknown scenario '{scen}' (one of {', '.join(SCENARIOS)})")
        if drive and drive not in DRIVES:
            raise UsageError(f"--plan: unknown drive '{drive}' (diff or forklift)")
        out.append((scen, drive or None))
    return out


def read_robot_nominal(path):
    import yaml
    with open(path, encoding="utf-8") as f:
        doc = yaml.safe_load(f)
    return doc


def make_plan(args):
    rng = random.Random(args.seed)
    if args.plan:
        plan = parse_plan(args.plan)
    else:
        n = args.robots
        counts = {"drift": round(n * args.drift_share), "step": round(n * args.step_share),
                  "effect": round(n * args.effect_share)}
        scen = ["drift"] * counts["drift"] + ["step"] * counts["step"] + ["effect"] * counts["effect"]
        scen += ["constant"] * (n - len(scen))
        if len(scen) > n:
            raise UsageError("--drift-share + --step-share + --effect-share exceed 1")
        rng.shuffle(scen)
        plan = [(s, None) for s in scen]
    return [(s, d or ("forklift" if i % 3 == 2 else "diff")) for i, (s, d) in enumerate(plan)]


def robot_truth(rng, drive, nominal):
    """Per robot: the true parameters at day 0 (nominal, perturbed)."""
    p = dict(nominal["params"])
    for k in DRIVES[drive]["radii"]:
        p[k] *= 1 + rng.gauss(0, 0.004)
    for k in DRIVES[drive]["lengths"]:
        p[k] *= 1 + rng.gauss(0, 0.003)
    if "steer_offset" in p:
        p["steer_offset"] = rng.gauss(0, 0.01)
    lid = nominal["lidar2d"]
    lidar = {"x": lid["x"] + rng.gauss(0, 0.01), "y": lid["y"] + rng.gauss(0, 0.01),
             "yaw": lid["yaw"] + rng.gauss(0, 0.01)}
    return {k: round(v, 6) for k, v in p.items()}, {k: round(v, 6) for k, v in lidar.items()}


def scenario_change(rng, scen, drive, days):
    """{kind, changes: {param: total change}, day} of a drift or step, or an effect."""
    sign = rng.choice((-1, 1))
    if scen == "drift":
        if rng.random() < 0.5:
            k = rng.choice(DRIVES[drive]["radii"])
            return {"kind": "tire_wear", "rel": {k: -rng.uniform(0.004, 0.008)}, "day": 0}
        return {"kind": "mount_loosening", "abs": {"lidar2d.yaw": sign * math.radians(rng.uniform(0.3, 0.6))}, "day": 0}
    if scen == "step":
        day = round(rng.uniform(0.3, 0.7) * days, 2)
        r = rng.random()
        if r < 0.5:
            return {"kind": "lidar_knock", "day": day,
                    "abs": {"lidar2d.yaw": sign * math.radians(rng.uniform(0.3, 0.6)),
                            "lidar2d.x": rng.choice((-1, 1)) * rng.uniform(0.003, 0.008)}}
        if drive == "diff":
            return {"kind": "tire_replaced", "day": day,
                    "rel": {rng.choice(DRIVES[drive]["radii"]): rng.uniform(0.005, 0.01)}}
        return {"kind": "steering_encoder_slip", "day": day,
                "abs": {"steer_offset": sign * math.radians(rng.uniform(0.1, 0.3))}}
    return None


def truth_at(base_params, base_lidar, change, day, days):
    """The truth on DAY: drifts linear over the span, steps from their day on."""
    p, lid = dict(base_params), dict(base_lidar)
    if change:
        frac = (day / days) if change["day"] == 0 else (1.0 if day >= change["day"] else 0.0)
        for k, rel in change.get("rel", {}).items():
            p[k] *= 1 + rel * frac
        for k, d in change.get("abs", {}).items():
            if k.startswith("lidar2d."):
                lid[k[8:]] += d * frac
            else:
                p[k] += d * frac
    return p, lid


def sim_yaml(robot_rel, seed, start, utime, params, lidar, drive, effect):
    fmt = lambda d: "{" + ", ".join(f"{k}: {v:.9g}" for k, v in d.items()) + "}"
    text = (f"robot: {robot_rel}\nseed: {seed}\nworld: warehouse\n"
            f"start: {{x: {start[0]:.3f}, y: {start[1]:.3f}, theta: {start[2]:.3f}}}\n"
            f"start_utime: {utime}\ntruth:\n  params: {fmt(params)}\n  lidar2d: {fmt(lidar)}\n"
            f"sensors:\n{DRIVES[drive]['sensors']}  lidar2d: {{rate: 20, beams: 720, range_noise: 0.01}}\n"
            "  imu: {rate: 0}\n  ground_truth: {rate: 0}\n")
    if effect:
        text += f"effects:\n  time_offset: {{offset_s: {EFFECT_OFFSET_S}}}\n"
    return text


def synth(args):
    out = os.path.abspath(args.out)
    if os.path.exists(os.path.join(out, "fleet.yaml")) and not args.force:
        raise UsageError(f"{out}: holds a fleet already (--force to overwrite)")
    agvcal = args.agvcal
    plan = make_plan(args)
    rng = random.Random(args.seed)
    days, m = args.days, args.recordings
    effect_day = round(args.effect_day if args.effect_day is not None else 0.6 * days, 2)
    truth = {"days": days, "epoch": EPOCH.isoformat(), "effect_day": effect_day,
             "effect": {"name": "time_offset", "offset_s": EFFECT_OFFSET_S}, "robots": {}}
    jobs, fleet = [], {}
    for i, (scen, drive) in enumerate(plan):
        rid = f"agv-{i + 1:03d}"
        nominal = read_robot_nominal(os.path.join(HERE, "config", "robots", DRIVES[drive]["robot"]))
        base_p, base_l = robot_truth(rng, drive, nominal)
        change = scenario_change(rng, scen, drive, days)
        os.makedirs(os.path.join(out, "robots"), exist_ok=True)
        with open(os.path.join(HERE, "config", "robots", DRIVES[drive]["robot"]), encoding="utf-8") as f:
            text = f.read()
        lines = [f"name: {rid}" if ln.startswith("name:") else ln for ln in text.splitlines()]
        with open(os.path.join(out, "robots", rid + ".yaml"), "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")
        fleet[rid] = {"robot": f"robots/{rid}.yaml", "recordings": f"logs/{rid}/*.log"}
        recs = []
        for k in range(m):
            slot = days / m
            day = round(k * slot + rng.uniform(0, 0.6 * slot), 2)
            hour = rng.uniform(6, 20)
            t = EPOCH + datetime.timedelta(days=int(day), hours=hour)
            day = int(day) + hour / 24  # the recording's time, in days since the epoch
            utime = int((t - datetime.datetime(1970, 1, 1, tzinfo=datetime.timezone.utc)).total_seconds()) * 1000000
            p, lid = truth_at(base_p, base_l, change, day, days)
            effect = scen == "effect" and day >= effect_day
            r = 1.5 * math.sqrt(rng.random())
            a = rng.uniform(-math.pi, math.pi)
            start = (r * math.cos(a), r * math.sin(a), rng.uniform(-math.pi, math.pi))
            seed = 1000 * (i + 1) + k
            name = f"{rid}_{t.strftime('%Y-%m-%d')}_{k:02d}"
            sim = os.path.join(out, "sims", rid, name + ".yaml")
            log = os.path.join(out, "logs", rid, name + ".log")
            os.makedirs(os.path.dirname(sim), exist_ok=True)
            os.makedirs(os.path.dirname(log), exist_ok=True)
            with open(sim, "w", encoding="utf-8") as f:
                f.write(sim_yaml(f"../../robots/{rid}.yaml", seed, start, utime, p, lid, drive, effect))
            jobs.append((sim, log))
            recs.append({"file": os.path.relpath(log, out), "day": day, "start_utime": utime,
                         "params": p, "lidar2d": lid, "effect": effect})
        entry = {"drive": drive, "scenario": scen, "recordings": recs}
        if change:
            entry.update(kind=change["kind"], change_day=change["day"],
                         changed={**{k: ("rel", v) for k, v in change.get("rel", {}).items()},
                                  **{k: ("abs", v) for k, v in change.get("abs", {}).items()}})
            if scen == "step":  # the first recording at the new truth
                entry["change_recording"] = next(
                    (j for j, rc in enumerate(recs) if rc["day"] >= change["day"]), None)
        if scen == "effect":
            entry["effect_recording"] = next((j for j, rc in enumerate(recs) if rc["effect"]), None)
        truth["robots"][rid] = entry
    with open(os.path.join(out, "fleet.yaml"), "w", encoding="utf-8") as f:
        f.write("# synthetic fleet (agvcal-fleet synth); truth in truth.json\nrobots:\n")
        for rid, e in fleet.items():
            f.write(f"  {rid}: {{robot: {e['robot']}, recordings: {e['recordings']}}}\n")
    with open(os.path.join(out, "truth.json"), "w", encoding="utf-8") as f:
        json.dump(truth, f, indent=1, sort_keys=True)

    def simulate(job):
        sim, log = job
        if os.path.exists(log) and not args.force:
            return None
        cmd = [agvcal, "simulate", sim, log + ".partial", "--trajectory", args.trajectory, "--quiet"]
        p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                           preexec_fn=(lambda: os.nice(args.nice)) if args.nice else None)
        if p.returncode:
            return f"{sim}: agvcal simulate exit {p.returncode}: {p.stderr.strip()[-300:]}"
        os.replace(log + ".partial", log)
        return None

    errors = []
    with cf.ThreadPoolExecutor(max_workers=args.jobs) as ex:
        for n, err in enumerate(ex.map(simulate, jobs), 1):
            if err:
                errors.append(err)
            if not args.quiet and (n % 100 == 0 or n == len(jobs)):
                print(f"agvcal-fleet synth: {n} of {len(jobs)} recordings", flush=True)
    if errors:
        raise RuntimeError(errors[0])
    for j in range(args.broken):  # truncated copies: a recording that fails
        rid = f"agv-{j % len(plan) + 1:03d}"
        src = os.path.join(out, truth["robots"][rid]["recordings"][-1]["file"])
        dst = os.path.join(out, "logs", rid, f"{rid}_9999-12-31_broken{j:02d}.log")
        with open(src, "rb") as f:
            data = f.read(100000)
        with open(dst, "wb") as f:
            f.write(data)
        truth["robots"][rid].setdefault("broken", []).append(os.path.relpath(dst, out))
    with open(os.path.join(out, "truth.json"), "w", encoding="utf-8") as f:
        json.dump(truth, f, indent=1, sort_keys=True)
    counts = {s: sum(1 for p in plan if p[0] == s) for s in SCENARIOS}
    if not args.quiet:
        print(f"agvcal-fleet synth: {len(plan)} robots ({', '.join(f'{v} {k}' for k, v in counts.items())}), "
              f"{len(jobs)} recordings in {out}")
    return 0
