#!/usr/bin/env python3
"""Checks `agvcal solve`'s ROS files against its RESULT.json (tests/e2e/rosbag.sh):

    check_ros_results.py RESULT.json CONTROLLER.yaml RECORDING [URDF TF.launch.xml LIDAR_FRAME]

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
    result_path, controller_path, recording = sys.argv[1:4]
    result = json.load(open(result_path))
    sha = hashlib.sha256(open(recording, "rb").read()).hexdigest()
    problems = []
    texts = {"controller": open(controller_path).read()}
    if len(sys.argv) > 4:
        texts.update(check_mount(result, *sys.argv[4:7], problems))
    check_controller(result, texts["controller"], problems)
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


def check_mount(result, urdf_path, tf_path, lidar, problems):

    mount = {k: result["lidar2d"][k]["value"] for k in ("x", "y", "yaw")}
    x, y, z, roll, pitch, yaw, parent, child = open(urdf_path + ".origin").read().split()
    for name, got, want in (("urdf x", x, mount["x"]), ("urdf y", y, mount["y"]), ("urdf yaw", yaw, mount["yaw"]),
                            ("urdf z", z, 0.0), ("urdf roll", roll, 0.0), ("urdf pitch", pitch, 0.0)):
        same(name, float(got), want, problems)
    if (parent, child) != ("base_link", lidar):
        problems.append(f"urdf joint {parent} -> {child}")

    tf_text = open(tf_path).read()
    node = ET.fromstring(tf_text).find("node")
    args = node.get("args").split()
    values = dict(zip(args[0::2], args[1::2]))
    for key in ("x", "y", "yaw"):
        same("tf " + key, float(values["--" + key]), mount[key], problems)
    if (values["--frame-id"], values["--child-frame-id"]) != ("base_link", lidar):
        problems.append(f"tf frames {values['--frame-id']} -> {values['--child-frame-id']}")
    return {"urdf": open(urdf_path).read(), "tf": tf_text}


def check_controller(result, controller_text, problems):
    params = result["params"]
    if "track" in params:
        p = yaml.safe_load(controller_text)["diff_drive_controller"]["ros__parameters"]
        radius = p["wheel_radius"]
        same("wheel_separation", p["wheel_separation"], params["track"]["value"], problems)
        same("left radius", radius * p["left_wheel_radius_multiplier"], params["left_radius"]["value"], problems)
        same("right radius", radius * p["right_wheel_radius_multiplier"], params["right_radius"]["value"], problems)
    else:
        p = yaml.safe_load(controller_text)["tricycle_controller"]["ros__parameters"]
        same("wheelbase", p["wheelbase"], params["wheelbase"]["value"], problems)
        same("wheel_radius", p["wheel_radius"], params["drive_radius"]["value"], problems)


if __name__ == "__main__":
    main()
