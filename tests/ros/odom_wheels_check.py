#!/usr/bin/env python3
"""Checks the WHEELS an import made from nav_msgs/Odometry (robot file ros.odom: {as: wheels})
against the poses the bag was written from, inverted here on their own (tests/e2e/ros_odom.sh):

    odom_wheels_check.py POSES.jsonl WHEELS.jsonl LEFT_RADIUS RIGHT_RADIUS TRACK

POSES.jsonl: the poses (x, y, theta, utime) as log_to_json.py writes them; WHEELS.jsonl: the
import's WHEELS, likewise. Between two poses the robot drives the SE(2) arc through both (the
exponential map's inverse); a differential drive's wheels turn by (s -+ dtheta track / 2) / r.
Every wheel position must agree to 1e-9 rad and every stamp exactly. Exit 1 with what differs.
"""
import json
import math
import sys


def arc(a, b):
    """(forward, sideways, turn) of the SE(2) arc from pose a to pose b."""
    c, s = math.cos(a["theta"]), math.sin(a["theta"])
    dx, dy = b["x"] - a["x"], b["y"] - a["y"]
    x, y = c * dx + s * dy, -s * dx + c * dy
    t = math.atan2(math.sin(b["theta"] - a["theta"]), math.cos(b["theta"] - a["theta"]))
    if abs(t) < 1e-9:
        return x, y, t
    half = t / 2
    k = half / math.tan(half)
    return k * x + half * y, -half * x + k * y, t


def main():
    poses = [json.loads(line) for line in open(sys.argv[1])]
    wheels = [json.loads(line) for line in open(sys.argv[2])]
    left_r, right_r, track = map(float, sys.argv[3:6])
    problems = []
    if len(poses) != len(wheels):
        problems.append(f"{len(poses)} poses but {len(wheels)} wheel states")
    left = right = 0.0
    for i, (p, w) in enumerate(zip(poses, wheels)):
        if i:
            forward, _, turn = arc(poses[i - 1], p)
            left += (forward - turn * track / 2) / left_r
            right += (forward + turn * track / 2) / right_r
        if w["utime"] != p["utime"]:
            problems.append(f"wheel state {i}: utime {w['utime']}, pose {p['utime']}")
        for name, got, want in (("left", w["position"][0], left), ("right", w["position"][1], right)):
            if abs(got - want) > 1e-9:
                problems.append(f"wheel state {i}: {name} {got!r}, expected {want!r}")
        if len(problems) > 5:
            break
    for p in problems:
        print(p, file=sys.stderr)
    if not problems:
        print(f"{len(wheels)} wheel states checked against the poses")
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
