#!/usr/bin/env python3
"""Checks `agvcal solve`'s ROS files against its RESULT.json (tests/e2e/rosbag.sh, ros_results.sh):

    check_ros_results.py RESULT.json CONTROLLER.yaml RECORDING [URDF TF.launch.xml LIDAR_FRAME]

and the mount files of `agvcal ground` and `recal` against the values they must hold
(EXPECTED.json: {"x": .., "y": .., "z": .., "roll": .., "pitch": .., "yaw": ..}, taken by the
caller from RESULT.json, the calibrated robot file or the robot file):

    check_ros_results.py mount EXPECTED.json RECORDING PARENT CHILD URDF TF.launch.xml [AUTOWARE.yaml]

URDF.origin beside URDF: urdf_joint_origin's output (liburdfdom's reading of it). The launch file is
parsed with xml.etree, the controller file with PyYAML; values must agree with RESULT.json to
1e-8 relative, the frames be base_link and LIDAR_FRAME, and each file name the recording's
SHA-256 and carry sigmas. Prints what differs; exit 1 then.
"""
import hashlib
import json
import sys
import xml.etree.ElementTree as ET

import yaml


def main():
    if sys.argv[1] == "mount":
        return main_mount()
    result_path, controller_path, recording = sys.argv[1:4]
    result = json.load(open(result_path))
    sha = hashlib.sha256(open(recording, "rb").read()).hexdigest()
    problems = []
    texts = {"controller": open(controller_path).read()}
    if len(sys.argv) > 4:
        mount = {axis: 0.0 for axis in AXES}
        mount.update({k: result["lidar2d"][k]["value"] for k in ("x", "y", "yaw")})
        urdf_path, tf_path, lidar = sys.argv[4:7]
        texts.update(check_mount(mount, urdf_path, tf_path, "base_link", lidar, problems))
    check_controller(result, texts["controller"], problems)
    finish(texts, sha, problems)


def main_mount():
    expected_path, recording, parent, child, urdf_path, tf_path = sys.argv[2:8]
    expected = json.load(open(expected_path))
    sha = hashlib.sha256(open(recording, "rb").read()).hexdigest()
    problems = []
    texts = check_mount(expected, urdf_path, tf_path, parent, child, problems)
    if len(sys.argv) > 8:
        texts["autoware"] = check_autoware(expected, sys.argv[8], parent, child, problems)
    finish(texts, sha, problems)


def finish(texts, sha, problems):
    for name, text in texts.items():
        if sha not in text:
            problems.append(f"{name}: no sha256 of the recording")
        if "sigma" not in text:
            problems.append(f"{name}: no sigma")
    for p in problems:
        print(p, file=sys.stderr)
    sys.exit(1 if problems else 0)


def same(what, got, want, problems):
    if abs(got - want) > 1e-8 * max(abs(want), 1e-3):
        problems.append(f"{what}: {got} in the file, {want} in RESULT.json")


AXES = ("x", "y", "z", "roll", "pitch", "yaw")


def check_mount(mount, urdf_path, tf_path, parent, lidar, problems):
    """URDF (liburdfdom's reading, URDF.origin) and tf launch file against `mount` (all six)."""
    *values, urdf_parent, urdf_child = open(urdf_path + ".origin").read().split()
    for axis, got in zip(AXES, values):
        same("urdf " + axis, float(got), mount[axis], problems)
    if (urdf_parent, urdf_child) != (parent, lidar):
        problems.append(f"urdf joint {urdf_parent} -> {urdf_child}")

    tf_text = open(tf_path).read()
    node = ET.fromstring(tf_text).find("node")
    args = node.get("args").split()
    values = dict(zip(args[0::2], args[1::2]))
    for axis in AXES:
        same("tf " + axis, float(values["--" + axis]), mount[axis], problems)
    if (values["--frame-id"], values["--child-frame-id"]) != (parent, lidar):
        problems.append(f"tf frames {values['--frame-id']} -> {values['--child-frame-id']}")
    return {"urdf": open(urdf_path).read(), "tf": tf_text}


def check_autoware(mount, path, parent, lidar, problems):
    """Autoware's sensors_calibration.yaml form: parent: child: {x, y, z, roll, pitch, yaw}."""
    text = open(path).read()
    frames = yaml.safe_load(text)
    if list(frames) != [parent] or list(frames[parent]) != [lidar]:
        problems.append(f"autoware frames: {frames}")
        return text
    for axis in AXES:
        same("autoware " + axis, frames[parent][lidar][axis], mount[axis], problems)
    return text


def check_controller(result, controller_text, problems):
    params = result["params"]
    if "track" in params:
        p = yaml.safe_load(controller_text)["diff_drive_controller"]["ros__parameters"]
        radius = p["wheel_radius"]
        same("wheel_separation", p["wheel_separation"], params["track"]["value"], problems)
        same("left radius", radius * p["left_wheel_radius_multiplier"], params["left_radius"]["value"], problems)
        same("right radius", radius * p["right_wheel_radius_multiplier"], params["right_radius"]["value"], problems)
    else:
        controllers = yaml.safe_load(controller_text)
        p = controllers["tricycle_controller"]["ros__parameters"]
        same("wheelbase", p["wheelbase"], params["wheelbase"]["value"], problems)
        same("wheel_radius", p["wheel_radius"], params["drive_radius"]["value"], problems)
        p = controllers["bicycle_steering_controller"]["ros__parameters"]
        same("bicycle wheelbase", p["wheelbase"], params["wheelbase"]["value"], problems)
        for key in ("traction_wheel_radius", "front_wheel_radius", "rear_wheel_radius"):
            same("bicycle " + key, p[key], params["drive_radius"]["value"], problems)
        offset = params["steer_offset"]["value"]
        if f"steering offset {offset:.9g} rad" not in controller_text:
            problems.append(f"no steering offset {offset:.9g} in the controller file")


if __name__ == "__main__":
    main()
