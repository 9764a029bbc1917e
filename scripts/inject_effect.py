#!/usr/bin/env python3
"""Writes a copy of a recording with one effect of spec/effects.md injected, exact in the
diagnosis's own terms (libcalib/src/diagnose/diagnose_model.h, docs/effects.md), for the
real-data injection suite (scripts/mismatch_real_injection.py, docs/mismatch-real-injection.md):

  inject_effect.py IN.log OUT.log ROBOT.yaml slip S R1[,R2]      longitudinal_slip of S s^2/m
  inject_effect.py IN.log OUT.log ROBOT.yaml eccentricity ROLE A P   wheel_eccentricity A, phase P rad
  inject_effect.py IN.log OUT.log ROBOT.yaml backlash ROLE W      steering_backlash of width W rad
  inject_effect.py IN.log OUT.log ROBOT.yaml offset CHANNEL D     every stamp on CHANNEL moved by D s

The recorded wheel stream is taken as the truth the effect acts on; the new readings are those
an encoder shows when the effect is present:
- slip: each wheel's positions p' solve p'_j - S*R*v'_j^2/2 = p_j at every sample, v' the
  diagnosis's speeds of p' itself (diagnose_fit.cc ChooseSpeedWindow: central differences over
  about +-50 ms; the least-squares slope over a wider window where the readings step unevenly),
  R the wheel's radius (the model's: give the calibrated one); the model's distance lost over any
  two samples is then the injected one to rounding. Solved by Newton (the Jacobian is banded
  within the window); the window comes from the injected readings, solved again until it settles.
- eccentricity: ROLE's angle phi' solves phi' + A*(sin(phi' - P) + sin P) = phi (A < 1).
- backlash: ROLE's steering reading gets + sign*W/2, sign the direction of the last steering motion
  by the diagnosis's rule (2 mrad hysteresis) on the readings written.
- offset: utime and the logger's stamp of every message on CHANNEL (WHEELS, SCAN, POSE) + D.
Exits 3 (and writes nothing) when the effect at this size is not realisable on the recording
(A >= 1, or the slip's equations have no solution near the recording: S*a reaches 1)."""
import math
import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests", "tools"))
from shift_scan_stamps import channel_events  # noqa: E402
from wheel_log import wheel_fields  # noqa: E402

STEER_HYSTERESIS = 0.002  # rad, diagnose_fit.cc MakeTrack
SPEED_SPAN_S = 0.05       # least half-width of the diagnosis's speed window
SPEED_ERROR = 0.015       # diagnose_fit.cc ChooseSpeedWindow kSpeedError
MAX_HALF_WIDTH_S = 0.3    # ... kMaxHalfWidthS


class NotRealisable(Exception):
    pass


def wheel_roles(robot_path):
    """role -> wheel name in the messages, from the robot file's `wheels:` mapping."""
    import yaml
    with open(robot_path) as f:
        return dict(yaml.safe_load(f)["wheels"])


def wheel_messages(data, src):
    """[(event offset, body offset, utime offset, {name: position offset}, {name: steer offset})]."""
    out = []
    for event, body in channel_events(data, src, "WHEELS"):
        msg = memoryview(data)[body:]
        utime_at, positions = wheel_fields(msg)
        n = len(positions)
        # position[n], velocity[n], steer[n] follow each other (spec/messages.md)
        steers = {name: at + 16 * n for name, at in positions.items()}
        out.append((event, body, body + utime_at, {k: body + v for k, v in positions.items()},
                    {k: body + v for k, v in steers.items()}))
        del msg
    if not out:
        sys.exit(f"{src}: no message on WHEELS")
    return out


def get(data, at):
    return struct.unpack_from(">d", data, at)[0]


def put(data, at, value):
    struct.pack_into(">d", data, at, value)


def step_irregularity(p, utimes):
    """How far the readings p stray from a smooth motion, as a share of a typical step
    (diagnose_fit.cc StepIrregularity: residuals from the cubic through two samples either side,
    the negative part of their lag-one covariance)."""
    n = len(p)
    if n < 8:
        return 0.0
    residual = []
    for i in range(2, n - 2):
        at = (i - 2, i - 1, i + 1, i + 2)
        smooth = 0.0
        for j in range(4):
            weight = 1.0
            for m in range(4):
                if m != j:
                    weight *= float(utimes[i] - utimes[at[m]]) / float(utimes[at[j]] - utimes[at[m]])
            smooth += weight * p[at[j]]
        residual.append(p[i] - smooth)
    covariance = sum(residual[i] * residual[i + 1] for i in range(len(residual) - 1)) / (len(residual) - 1)
    displacement = math.sqrt(max(0.0, -covariance) * 36.0 / 56.0)
    steps = [p[i + 1] - p[i] for i in range(n - 1) if p[i + 1] != p[i]]
    return displacement / math.sqrt(sum(x * x for x in steps) / len(steps)) if steps else 0.0


def speed_window(utimes, wheels):
    """The diagnosis's speed window (diagnose_fit.cc ChooseSpeedWindow) for the wheel positions
    `wheels` (one list per wheel of the drive): (half-width k in samples, least-squares slope)."""
    n = len(utimes)
    dt = max((utimes[-1] - utimes[0]) * 1e-6 / (n - 1), 1e-4)
    cap = max(1, n // 8)
    least = min(max(1, int(math.floor(SPEED_SPAN_S / dt + 0.5))), cap)
    most = max(least, min(cap, int(MAX_HALF_WIDTH_S / dt + 1e-6)))  # (0.3 / 0.05 < 6)
    irregularity = max([step_irregularity(p, utimes) for p in wheels] + [0.0])
    if most == least or irregularity * math.sqrt(0.5) / least <= SPEED_ERROR:
        return least, False
    k = least + 1
    while k < most and irregularity / math.sqrt(k * (k + 1.0) * (2 * k + 1) / 3) > SPEED_ERROR:
        k += 1
    return min(k, most), True


def speed_weights(utimes, window):
    """Per sample j, (first sample, weights): the diagnosis's speed v_j = sum of weight * p over the
    window (diagnose_model.h WindowSlope)."""
    k, least_squares = window
    n = len(utimes)
    rows = []
    for j in range(n):
        lo, hi = max(0, j - k), min(n - 1, j + k)
        if not least_squares:
            span = (utimes[hi] - utimes[lo]) * 1e-6
            rows.append((lo, [-1 / span] + [0.0] * (hi - lo - 1) + [1 / span]))
            continue
        t = [(utimes[m] - utimes[j]) * 1e-6 for m in range(lo, hi + 1)]
        mean = sum(t) / len(t)
        d = [x - mean for x in t]
        stt = sum(x * x for x in d)
        rows.append((lo, [x / stt for x in d]))
    return rows


def solve_banded(rows, rhs, k):
    """x with A x = rhs, A given as rows[i] = {column: value} within +-k of the diagonal (Gaussian
    elimination without pivoting: the slip's Jacobian is the identity plus a small band)."""
    n = len(rhs)
    a = [dict(r) for r in rows]
    b = list(rhs)
    for c in range(n):
        pivot = a[c].get(c, 0.0)
        if not abs(pivot) > 1e-9:
            raise NotRealisable("the slip's equations are singular on this recording")
        for r in range(c + 1, min(n, c + k + 1)):
            factor = a[r].get(c, 0.0) / pivot
            if factor == 0.0:
                continue
            for col, value in a[c].items():
                if col >= c:
                    a[r][col] = a[r].get(col, 0.0) - factor * value
            b[r] -= factor * b[c]
    x = [0.0] * n
    for i in range(n - 1, -1, -1):
        x[i] = (b[i] - sum(value * x[col] for col, value in a[i].items() if col > i)) / a[i][i]
    return x


def solve_slip(g, utimes, slip, radius, window):
    """p with p_j - slip*radius*v_j^2/2 = g_j, v the diagnosis's speeds of p over `window`
    (module doc); Newton, its Jacobian banded within the window."""
    n = len(g)
    rows = speed_weights(utimes, window)
    h = 0.5 * slip * radius
    p = list(g)
    for _ in range(60):
        v = [sum(w * p[lo + q] for q, w in enumerate(ws)) for lo, ws in rows]
        f = [p[j] - h * v[j] * v[j] - g[j] for j in range(n)]
        if max(abs(x) for x in f) < 1e-11:
            return p
        jacobian = []
        for j, (lo, ws) in enumerate(rows):
            row = {lo + q: -2 * h * v[j] * w for q, w in enumerate(ws) if w != 0.0}
            row[j] = row.get(j, 0.0) + 1.0
            jacobian.append(row)
        step = solve_banded(jacobian, [-x for x in f], window[0])
        p = [p[j] + step[j] for j in range(n)]
        if not all(math.isfinite(x) for x in p):
            break
    raise NotRealisable("the slip's equations do not converge on this recording (slip x acceleration reaches 1)")


def solve_eccentricity(phi, amplitude, phase):
    """phi' with phi' + A (sin(phi' - P) + sin P) = phi, per sample (Newton; monotone for A < 1)."""
    if not amplitude < 1:
        raise NotRealisable(f"an eccentricity amplitude of {amplitude} (>= 1) turns the wheel backwards")
    out, x = [], phi[0]
    for target in phi:
        x = x if abs(x - target) < 2 * amplitude + 1 else target
        for _ in range(100):
            f = x + amplitude * (math.sin(x - phase) + math.sin(phase)) - target
            if abs(f) < 1e-13:
                break
            x -= f / (1 + amplitude * math.cos(x - phase))
        out.append(x)
    return out


def backlash_readings(steer, width):
    """steer + sign*width/2, sign the direction of the last steering motion by MakeTrack's rule
    applied to the readings written (so ties at the hysteresis fall the same way there)."""
    out, sign, extreme = [], 0, steer[0]
    for s in steer:
        x = s + sign * width / 2
        if sign >= 0 and x < extreme - STEER_HYSTERESIS:
            sign = -1
            x = extreme = s - width / 2
        elif sign <= 0 and x > extreme + STEER_HYSTERESIS:
            sign = 1
            x = extreme = s + width / 2
        elif (sign > 0 and x > extreme) or (sign < 0 and x < extreme):
            extreme = x
        out.append(x)
    return out


def inject(data, src, robot, effect, args):
    if effect == "offset":
        channel, shift_us = args[0], int(round(float(args[1]) * 1e6))
        moved = 0
        for event, body in channel_events(data, src, channel):
            for at in (event + 12, body + 8):
                struct.pack_into(">q", data, at, struct.unpack_from(">q", data, at)[0] + shift_us)
            moved += 1
        if moved == 0:
            sys.exit(f"{src}: no message on {channel}")
        return
    roles = wheel_roles(robot)
    msgs = wheel_messages(data, src)
    utimes = [struct.unpack_from(">q", data, m[2])[0] for m in msgs]
    if effect == "slip":
        radii = [float(r) for r in args[1].split(",")]
        recorded = [[get(data, m[3][name]) for m in msgs] for name in roles.values()]
        # The half-width comes from the readings the diagnosis sees, the injected ones: solved
        # again until the half-width of the solution is the one it was solved with.
        window = speed_window(utimes, recorded)
        for _ in range(4):
            solved = [solve_slip(g, utimes, float(args[0]), radius, window) for g, radius in zip(recorded, radii)]
            window_solved = speed_window(utimes, solved)
            if window_solved == window:
                break
            window = window_solved
        else:
            raise NotRealisable("the speeds' half-width does not settle on this recording")
        for name, p in zip(roles.values(), solved):
            for m, value in zip(msgs, p):
                put(data, m[3][name], value)
    elif effect == "eccentricity":
        name = roles[args[0]]
        phi = [get(data, m[3][name]) for m in msgs]
        for m, value in zip(msgs, solve_eccentricity(phi, float(args[1]), float(args[2]))):
            put(data, m[3][name], value)
    elif effect == "backlash":
        name = roles[args[0]]
        steer = [get(data, m[4][name]) for m in msgs]
        for m, value in zip(msgs, backlash_readings(steer, float(args[1]))):
            put(data, m[4][name], value)
    else:
        sys.exit(f"unknown effect {effect} (slip, eccentricity, backlash, offset)")


def main(argv):
    if len(argv) < 6 or argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(argv) > 1 and argv[1] in ("-h", "--help") else 2
    src, dst, robot, effect = argv[1:5]
    data = bytearray(open(src, "rb").read())
    try:
        inject(data, src, robot, effect, argv[5:])
    except NotRealisable as e:
        print(f"{src}: {effect} {' '.join(argv[5:])}: not realisable: {e}", file=sys.stderr)
        return 3
    with open(dst, "wb") as f:
        f.write(data)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
