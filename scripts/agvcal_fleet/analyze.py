"""Decisions from the database: per robot and parameter a drift test and a step test, per
robot the effects it shows now, over the fleet the effects that appear in many robots at
once. Reads the database only (never a simulator's truth). docs/fleet.md has the method.

Multiplicity: every (robot, parameter) series gets two tests (drift, step); with m such tests
over the fleet a test's p-value is multiplied by m (Bonferroni; the step test's own p-value
already counts its candidate change points), and a finding is declared when the adjusted
p-value is at most alpha. The probability that any finding is declared on a fleet whose
parameters are constant is then at most alpha (default 1 %), provided the sigmas, widened by
the fleet's pooled noise scale, describe the scatter.
"""
import json
import math

from . import db as dbmod
from . import stats

DAY_US = 86400e6
# The parameter that gives an effect's size (spec/effects.md).
EFFECT_SIZE_PARAM = {"time_offset": "offset_s", "scan_distortion": "scan_period_s",
                     "longitudinal_slip": "slip_per_accel", "lateral_slip": "gain",
                     "steering_lag": "tau_s", "steering_backlash": "width_rad",
                     "wheel_eccentricity": "amplitude", "drive_lag": "tau_s",
                     "steering_rate_limit": "rate_rad_s"}
# The chance that a robot shows a new effect in two consecutive recordings without the
# physics having changed: diagnose's family-wise false-alarm rate (1 % per recording over
# its whole catalogue, docs/mismatch.md), squared.
CHANCE_ONSET = 0.01 ** 2


class Recording:
    __slots__ = ("sha", "path", "utime", "day", "solve_exit", "solve_message", "diag_exit",
                 "diag_message", "info_exit", "info_message", "heldout", "params", "effects",
                 "distance_m", "duration_s")


def load(db):
    """{robot_id: {"drive", "robot_file", "recordings": [Recording in time order]}}"""
    robots = {r["robot_id"]: {"drive": r["drive"], "robot_file": r["robot_file"], "recordings": []}
              for r in db.query_dicts("SELECT robot_id, drive, robot_file FROM robots ORDER BY robot_id")}
    rows = db.query_dicts(
        "SELECT r.robot_id, r.sha256, r.path, r.start_utime, r.info_exit, r.info_message, "
        "r.distance_m, r.duration_s, c.exit_status AS solve_exit, c.message AS solve_message, "
        "c.heldout_verdict, c.heldout_nominal_error_per_m, c.heldout_calibrated_error_per_m, "
        "c.heldout_sign_p, c.heldout_halves_p, c.heldout_halves_largest, "
        "d.exit_status AS diag_exit, d.message AS diag_message "
        "FROM recordings r LEFT JOIN calibrations c ON c.recording_sha256 = r.sha256 "
        "LEFT JOIN diagnoses d ON d.recording_sha256 = r.sha256")
    by_sha = {}
    for row in rows:
        rec = Recording()
        rec.sha, rec.path, rec.utime = row["sha256"], row["path"], row["start_utime"]
        rec.day = rec.utime / DAY_US if rec.utime is not None else None
        rec.solve_exit, rec.solve_message = row["solve_exit"], row["solve_message"]
        rec.diag_exit, rec.diag_message = row["diag_exit"], row["diag_message"]
        rec.info_exit, rec.info_message = row["info_exit"], row["info_message"]
        rec.distance_m, rec.duration_s = row["distance_m"], row["duration_s"]
        rec.heldout = {k: row[k] for k in ("heldout_verdict", "heldout_nominal_error_per_m",
                                           "heldout_calibrated_error_per_m", "heldout_sign_p",
                                           "heldout_halves_p", "heldout_halves_largest")}
        rec.params, rec.effects = {}, {}
        robots.setdefault(row["robot_id"], {"drive": None, "robot_file": None, "recordings": []})
        robots[row["robot_id"]]["recordings"].append(rec)
        by_sha[rec.sha] = rec
    for sha, name, value, std, nominal in db.query(
            "SELECT recording_sha256, name, value, std, nominal FROM calibration_params"):
        if sha in by_sha:
            by_sha[sha].params[name] = (value, std, nominal)
    for sha, effect, wheel, param, value, std in db.query(
            "SELECT recording_sha256, effect, wheel, param, value, std FROM diagnosis_effects"):
        if sha in by_sha:
            key = effect + (f":{wheel}" if wheel else "")
            by_sha[sha].effects.setdefault(key, {})[param] = (value, std)
    for r in robots.values():
        r["recordings"].sort(key=lambda x: (x.utime is None, x.utime or 0, x.path))
    return robots


def param_series(recs, name):
    """The recordings whose calibration gave NAME with a positive sigma, in time order."""
    out = [r for r in recs if r.solve_exit == 0 and r.utime is not None and name in r.params
           and r.params[name][1] and r.params[name][1] > 0 and math.isfinite(r.params[name][0])]
    return out


def effect_key_param(key, params):
    name = key.split(":")[0]
    p = EFFECT_SIZE_PARAM.get(name)
    return p if p in params else sorted(params)[0]


def analyze(robots, alpha=0.01, min_recordings=5, window_days=7.0, fleet_min_robots=3):
    """Returns {"findings": [...], "series": {robot: {param: {...fit...}}}, "scales": {...},
    "tests": m}. Findings are dicts with robot_id, kind (drift, step, effect, fleet_effect,
    failed, heldout), subject, p_value (adjusted), first_sha256, first_utime, change_utime,
    size, size_std, detail (dict), why (one line)."""
    # 1. the series, and the pooled noise scale per (drive, parameter)
    series = {}
    keys = []  # (robot, parameter, drive) of every series, in order
    for rid, rob in robots.items():
        names = sorted({n for r in rob["recordings"] for n in r.params})
        for name in names:
            recs = param_series(rob["recordings"], name)
            if len(recs) < min_recordings:
                continue
            t = [r.day for r in recs]
            y = [r.params[name][0] for r in recs]
            s = [r.params[name][1] for r in recs]
            series.setdefault(rid, {})[name] = {"recs": recs, "t": t, "y": y, "s": s}
            keys.append((rid, name, rob["drive"]))
    all_series = [series[rid][name] for rid, name, _ in keys]
    lines = [(x["t"], x["y"], x["s"]) for x in all_series]
    levels = [(x["y"], x["s"]) for x in all_series]
    fits = {}
    for (rid, name, drive), d, st in zip(keys, stats.drift_tests(lines), stats.step_tests(levels)):
        # the scatter about the better of the two models, so that a robot that drifts or
        # steps does not widen the scale (with few robots a single one would decide it)
        chi2 = min(d["chi2"], st["chi2"]) if st else d["chi2"]
        fits.setdefault((drive, name), []).append((chi2, len(series[rid][name]["y"])))
    scales = {k: stats.pooled_scale(v) for k, v in fits.items()}
    m = 2 * len(keys)
    findings = []

    def adjusted(p):
        return min(1.0, p * m)

    # 2. drift and step per series
    f_all = [scales[(drive, name)] for _, name, drive in keys]
    for (rid, name, _), ser, f, d, st in zip(keys, all_series, f_all, stats.drift_tests(lines, f_all),
                                             stats.step_tests(levels, f_all)):
        t, y, s, recs = ser["t"], ser["y"], ser["s"], ser["recs"]
        d["p_adj"] = adjusted(d["p"])
        ser.update(scale=f, drift=d, step=st)
        if st:
            st["p_adj"] = adjusted(st["p"])
        drift_sig = d["p_adj"] <= alpha
        step_sig = st is not None and st["p_adj"] <= alpha
        if not (drift_sig or step_sig):
            ser["model"] = "constant"
            continue
        kind = "step" if step_sig and (not drift_sig or st["chi2"] < d["chi2"]) else "drift"
        ser["model"] = kind
        span = t[-1] - t[0]
        nominal = recs[0].params[name][2]
        if kind == "drift":
            first = None
            for k in range(max(3, min_recordings), len(y) + 1):
                dk = stats.drift_test(t[:k], y[:k], s[:k], f)
                if adjusted(dk["p"]) <= alpha:
                    first = k - 1
                    break
            first = len(y) - 1 if first is None else first
            fr = recs[first]
            findings.append({
                "robot_id": rid, "kind": "drift", "subject": name, "p_value": d["p_adj"],
                "first_sha256": fr.sha, "first_utime": fr.utime, "change_utime": None,
                "size": d["slope"] * span, "size_std": d["slope_std"] * span,
                "detail": {"per_30_days": d["slope"] * 30, "per_30_days_std": d["slope_std"] * 30,
                           "z": d["z"], "scale": f, "recordings": len(y), "span_days": span,
                           "step_p": st["p_adj"] if st else None, "nominal": nominal,
                           "first_index": first, "first_path": fr.path}})
        else:
            k = st["k"]
            alarm = None
            for j in range(4, len(y) + 1):
                sj = stats.step_test(y[:j], s[:j], f)
                if sj and adjusted(sj["p"]) <= alpha:
                    alarm = j - 1
                    break
            fr = recs[k]
            findings.append({
                "robot_id": rid, "kind": "step", "subject": name, "p_value": st["p_adj"],
                "first_sha256": fr.sha, "first_utime": fr.utime, "change_utime": fr.utime,
                "size": st["size"], "size_std": st["size_std"],
                "detail": {"z": st["z"], "scale": f, "recordings": len(y), "change_index": k,
                           "last_before_utime": recs[k - 1].utime, "before": st["before"],
                           "after": st["after"], "splits": st["splits"],
                           "drift_p": d["p_adj"], "nominal": nominal, "first_path": fr.path,
                           "alarm_index": alarm,
                           "alarm_utime": recs[alarm].utime if alarm is not None else None}})

    # 3. effects per robot: present now, and onsets (found in two consecutive recordings
    #    after two without, and in at most a quarter of the recordings before)
    onsets = {}  # effect key -> [(day, robot, rec index, size, recording)]
    for rid, rob in robots.items():
        recs = [r for r in rob["recordings"] if r.diag_exit == 0 and r.utime is not None]
        for key in sorted({k for r in recs for k in r.effects}):
            found = [key in r.effects for r in recs]
            if len(recs) >= 2 and sum(found[-3:]) >= 2:
                with_it = [r for r in recs[-3:] if key in r.effects]
                param = effect_key_param(key, with_it[-1].effects[key])
                vals = [r.effects[key][param] for r in with_it if param in r.effects[key]]
                since = next(j for j in range(len(found))
                             if found[j] and sum(found[j:]) >= 0.75 * (len(found) - j))
                fr = recs[since]
                findings.append({
                    "robot_id": rid, "kind": "effect", "subject": key, "p_value": None,
                    "first_sha256": fr.sha, "first_utime": fr.utime, "change_utime": None,
                    "size": stats.median([v for v, _ in vals]),
                    "size_std": stats.median([sd for _, sd in vals if sd is not None] or [math.nan]),
                    "detail": {"found_in": sum(found), "of": len(found), "last_found": sum(found[-3:]),
                               "param": param, "first_path": fr.path}})
            for j in range(2, len(recs) - 1):
                if (found[j] and found[j + 1] and not found[j - 1] and not found[j - 2]
                        and sum(found[:j]) <= 0.25 * j):
                    e = recs[j].effects[key]
                    onsets.setdefault(key, []).append(
                        (recs[j].day, rid, j, e[effect_key_param(key, e)][0], recs[j]))
                    break

    # 4. fleet-wide: onsets of one effect in several robots within window_days
    candidates = []
    for key, ons in onsets.items():
        ons = sorted(ons)
        used = set()
        while True:
            best = None
            for day, *_ in ons:
                win = [o for o in ons if day <= o[0] < day + window_days and o[1] not in used]
                if best is None or len(win) > len(best[1]):
                    best = (day, win)
            if best is None or len(best[1]) < fleet_min_robots:
                break
            candidates.append((key, best[0], best[1]))
            used |= {o[1] for o in best[1]}
    # the family: a window may start on any day of the fleet's span, for any catalogue effect
    days_all = [r.day for rob in robots.values() for r in rob["recordings"] if r.day is not None]
    n_windows = max(1, math.ceil(max(days_all) - min(days_all))) if days_all else 1
    family = n_windows * max(len(EFFECT_SIZE_PARAM), len(onsets))
    for key, day0, win in candidates:
        # robots that could show an onset in the window: diagnosed before and after it
        n = 0
        for rid, rob in robots.items():
            days = [r.day for r in rob["recordings"] if r.diag_exit == 0 and r.day is not None]
            if sum(d < day0 for d in days) >= 2 and sum(d >= day0 for d in days) >= 2:
                n += 1
        p = stats.binomial_sf(len(win), max(n, len(win)), CHANCE_ONSET)
        p_adj = min(1.0, p * family)
        if p_adj > alpha:
            continue
        first = min(win, key=lambda o: o[0])
        findings.append({
            "robot_id": "*", "kind": "fleet_effect", "subject": key, "p_value": p_adj,
            "first_sha256": first[4].sha, "first_utime": first[4].utime,
            "change_utime": first[4].utime, "size": stats.median([o[3] for o in win]),
            "size_std": None,
            "detail": {"robots": [o[1] for o in sorted(win, key=lambda o: o[1])],
                       "first_recordings": {o[1]: o[4].path for o in win},
                       "share": len(win) / max(n, 1), "robots_observed": n,
                       "window_days": window_days, "last_utime": max(o[4].utime for o in win)}})

    # 5. failed recordings and held-out verdicts, per robot
    for rid, rob in robots.items():
        recs = rob["recordings"]
        bad = [r for r in recs if r.solve_exit != 0 or r.diag_exit != 0]
        if bad:
            r = bad[-1]
            which = "solve" if r.solve_exit != 0 else "diagnose"
            status = r.solve_exit if which == "solve" else r.diag_exit
            msg = r.solve_message if which == "solve" else r.diag_message
            findings.append({
                "robot_id": rid, "kind": "failed", "subject": f"{which} exit {status}",
                "p_value": None, "first_sha256": r.sha, "first_utime": r.utime,
                "change_utime": None, "size": len(bad), "size_std": None,
                "detail": {"failed": len(bad), "of": len(recs), "message": msg, "path": r.path,
                           "exit_status": status}})
        done = [r for r in recs if r.solve_exit == 0 and r.heldout.get("heldout_verdict")]
        if done and done[-1].heldout["heldout_verdict"] == "worse":
            r = done[-1]
            findings.append({
                "robot_id": rid, "kind": "heldout", "subject": "calibration worse than nominal",
                "p_value": r.heldout["heldout_sign_p"], "first_sha256": r.sha,
                "first_utime": r.utime, "change_utime": None,
                "size": r.heldout["heldout_calibrated_error_per_m"], "size_std": None,
                "detail": {"nominal_error_per_m": r.heldout["heldout_nominal_error_per_m"],
                           "path": r.path}})
    order = {"fleet_effect": 0, "step": 1, "drift": 2, "failed": 3, "effect": 4, "heldout": 5}
    findings.sort(key=lambda x: (x["robot_id"] != "*", x["robot_id"], order[x["kind"]], x["subject"]))
    for fnd in findings:
        fnd["why"] = describe(fnd)
    return {"findings": findings, "series": series, "scales": {f"{d}/{n}": v for (d, n), v in scales.items()},
            "tests": m, "alpha": alpha}


# -- words ---------------------------------------------------------------------------------
def is_angle(name):
    return name.endswith("yaw") or name.endswith("steer_offset") or name.endswith("pitch") or name.endswith("roll")


def param_unit(name):
    """(factor, unit) in which a person reads a parameter (docs/units.md): angles in degrees,
    the time offset in ms, lengths in mm."""
    if is_angle(name):
        return 180 / math.pi, "deg"
    if name.endswith("time_offset"):
        return 1e3, "ms"
    return 1e3, "mm"


def fmt_param(name, v, signed=True):
    """A parameter value (or change) in readable units: angles in degrees, lengths in mm."""
    if v is None or not math.isfinite(v):
        return "n/a"
    k, unit = param_unit(name)
    return f"{v * k:{'+' if signed else ''}.{3 if unit == 'deg' else 2}f} {unit}"


def fmt_p(p):
    """A p-value in a sentence as the C++ outputs write it (calib::PValueText): two significant
    digits, "p < 1e-12" below 1e-12, where the tail is numerical noise; never "p = 0"."""
    if p is None or math.isnan(p):
        return "p = n/a"
    return "p < 1e-12" if p < 1e-12 else f"p = {p:.2g}"


def fmt_error_per_m(v):
    """An odometry error per metre of path in mm/m, as the solve report writes it."""
    return "n/a" if v is None or not math.isfinite(v) else f"{v * 1e3:.1f} mm/m"


# (factor, unit) of each effect's size parameter as a person reads it (SI in docs/spec/effects.md).
EFFECT_UNITS = {"offset_s": (1e3, "ms"), "scan_period_s": (1e3, "ms"), "tau_s": (1e3, "ms"),
                "gain": (1e3, "ms"), "slip_per_accel": (1.0, "s²/m"), "width_rad": (180 / math.pi, "deg"),
                "rate_rad_s": (180 / math.pi, "deg/s"), "amplitude": (100.0, "% of the radius")}


def effect_unit(param):
    return EFFECT_UNITS.get(param, (1.0, param))


def fmt_effect(key, v):
    if v is None or not math.isfinite(v):
        return "n/a"
    k, unit = effect_unit(EFFECT_SIZE_PARAM.get(key.split(":")[0], ""))
    return f"{v * k:.{3 if unit == 'deg' else 2}f} {unit}" if unit in ("ms", "deg") else f"{v * k:.3g} {unit}".rstrip()


def date(utime):
    import datetime
    if utime is None:
        return "?"
    return datetime.datetime.fromtimestamp(utime / 1e6, datetime.timezone.utc).strftime("%Y-%m-%d")


def describe(f):
    k, d = f["kind"], f["detail"]
    if k == "drift":
        rel = ""
        if d.get("nominal"):
            rel = f" ({100 * f['size'] / abs(d['nominal']):+.2f} % of nominal)" if not is_angle(f["subject"]) else ""
        return (f"{f['subject']} drifts {fmt_param(f['subject'], f['size'])}{rel} over "
                f"{d['span_days']:.0f} days ({fmt_param(f['subject'], d['per_30_days'])} per 30 days, "
                f"z = {d['z']:.1f}, {fmt_p(f['p_value'])}); shows from {date(f['first_utime'])}")
    if k == "step":
        return (f"{f['subject']} stepped by {fmt_param(f['subject'], f['size'])} "
                f"(± {fmt_param(f['subject'], f['size_std'], False)}, {fmt_p(f['p_value'])}) between "
                f"{date(d['last_before_utime'])} and {date(f['change_utime'])}")
    if k == "effect":
        return (f"{f['subject']} ({fmt_effect(f['subject'], f['size'])}) found in "
                f"{d['last_found']} of the last 3 recordings ({d['found_in']} of {d['of']} in all), "
                f"since {date(f['first_utime'])}")
    if k == "fleet_effect":
        return (f"{f['subject']} appeared in {len(d['robots'])} robots "
                f"({100 * d['share']:.0f} % of the {d['robots_observed']} observed) between "
                f"{date(f['first_utime'])} and {date(d['last_utime'])}, median "
                f"{fmt_effect(f['subject'], f['size'])} ({fmt_p(f['p_value'])})")
    if k == "failed":
        return (f"{d['failed']} of {d['of']} recordings failed; last: {f['subject']}: {d['message']}")
    if k == "heldout":
        return (f"the latest calibration predicts held-out data worse than nominal "
                f"({fmt_error_per_m(d['nominal_error_per_m'])} -> {fmt_error_per_m(f['size'])})")
    return k


def store(db, findings):
    with db.transaction():
        db.execute("DELETE FROM findings")
        for f in findings:
            db.insert("findings", {k: f[k] for k in ("robot_id", "kind", "subject", "p_value",
                                                     "first_sha256", "first_utime", "change_utime",
                                                     "size", "size_std")}
                      | {"detail": dbmod.dumps(f["detail"])})


def write_json(path, result):
    with open(path, "w", encoding="utf-8") as f:
        json.dump({k: result[k] for k in ("findings", "scales", "tests", "alpha")}, f,
                  indent=1, sort_keys=True, default=str)


def summary(robots, result):
    """The findings as the lines `analyze` prints."""
    n_rec = sum(len(r["recordings"]) for r in robots.values())
    attention = sorted({f["robot_id"] for f in result["findings"] if f["robot_id"] != "*"})
    lines = [f"{len(robots)} robots, {n_rec} recordings, {result['tests']} trend tests at a "
             f"family-wise false-alarm rate of {result['alpha']:g}; {len(attention)} robots need attention"]
    for f in result["findings"]:
        who = "fleet" if f["robot_id"] == "*" else f["robot_id"]
        lines.append(f"  {who:<12} {f['kind']:<12} {f['why']}")
    return lines
