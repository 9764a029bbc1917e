"""Which recordings belong to which robot: a fleet.yaml, or a folder tree.

fleet.yaml (paths relative to the file):

    robots:
      agv-001:
        robot: robots/agv-001.yaml          # the robot file agvcal solves with
        recordings: logs/agv-001/*.log      # a glob, or a list of globs / paths
      agv-002: {robot: robots/agv-002.yaml, recordings: [logs/agv-002/*.log, old/agv-002-*.log]}

A folder tree instead: every folder below the given one that holds a `robot.yaml` is a
robot, named by its path below the root (`site-a/agv-001`); its recordings are the `*.log`
files anywhere below that folder (not below a nested robot's folder).
"""
import glob
import os

import yaml

from .errors import UsageError


class Robot:
    def __init__(self, robot_id, robot_file, recordings):
        self.robot_id = robot_id
        self.robot_file = robot_file
        self.recordings = recordings  # absolute paths, sorted

    def __repr__(self):
        return f"Robot({self.robot_id!r}, {self.robot_file!r}, {len(self.recordings)} recordings)"


def load(path):
    """The fleet at PATH (a fleet.yaml or a folder tree) as a list of Robot, sorted by id."""
    if os.path.isdir(path):
        return _from_tree(os.path.abspath(path))
    if not os.path.exists(path):
        raise UsageError(f"{path}: no such fleet file or folder")
    return _from_yaml(os.path.abspath(path))


def _fail(path, key, problem):
    raise UsageError(f"{path}: {key}: {problem}")


def _from_yaml(path):
    try:
        with open(path, encoding="utf-8") as f:
            doc = yaml.safe_load(f)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark else "yaml"
        raise UsageError(f"{path}: {where}: not valid YAML ({getattr(e, 'problem', e)})")
    except OSError as e:
        raise UsageError(f"{path}: cannot read ({e.strerror})")
    if not isinstance(doc, dict) or "robots" not in doc:
        _fail(path, "robots", "missing (a map of robot id -> {robot: FILE, recordings: GLOB})")
    unknown = set(doc) - {"robots"}
    if unknown:
        _fail(path, sorted(unknown)[0], "unknown key (expected only 'robots')")
    robots = doc["robots"]
    if not isinstance(robots, dict) or not robots:
        _fail(path, "robots", "must be a non-empty map of robot id -> {robot, recordings}")
    base = os.path.dirname(path)
    out = []
    for rid, entry in robots.items():
        key = f"robots.{rid}"
        if not isinstance(rid, str) or not rid.strip():
            _fail(path, key, "a robot id is a non-empty string")
        if not isinstance(entry, dict):
            _fail(path, key, "must be a map with 'robot' and 'recordings'")
        unknown = set(entry) - {"robot", "recordings"}
        if unknown:
            _fail(path, f"{key}.{sorted(unknown)[0]}", "unknown key (expected robot, recordings)")
        robot_file = entry.get("robot")
        if not isinstance(robot_file, str) or not robot_file:
            _fail(path, f"{key}.robot", "missing (the path of the robot file)")
        robot_file = os.path.normpath(os.path.join(base, robot_file))
        if not os.path.isfile(robot_file):
            _fail(path, f"{key}.robot", f"no such file: {robot_file}")
        patterns = entry.get("recordings")
        if isinstance(patterns, str):
            patterns = [patterns]
        if not isinstance(patterns, list) or not patterns or not all(isinstance(p, str) for p in patterns):
            _fail(path, f"{key}.recordings", "missing (a glob or a list of globs of recordings)")
        recs = set()
        for p in patterns:
            recs.update(os.path.normpath(m) for m in glob.glob(os.path.join(base, p), recursive=True)
                        if os.path.isfile(m))
        out.append(Robot(rid, robot_file, sorted(recs)))
    return sorted(out, key=lambda r: r.robot_id)


def _from_tree(root):
    robot_dirs = sorted(d for d, _, files in os.walk(root) if "robot.yaml" in files)
    if not robot_dirs:
        raise UsageError(f"{root}: no robot.yaml in any folder below it (or give a fleet.yaml)")
    out = []
    for d in robot_dirs:
        nested = [o for o in robot_dirs if o != d and o.startswith(d + os.sep)]
        recs = []
        for sub, dirs, files in os.walk(d):
            if any(sub == o or sub.startswith(o + os.sep) for o in nested):
                continue
            recs += [os.path.join(sub, f) for f in files if f.endswith(".log")]
        rid = os.path.relpath(d, root) if d != root else os.path.basename(root)
        out.append(Robot(rid.replace(os.sep, "/"), os.path.join(d, "robot.yaml"), sorted(recs)))
    return out
