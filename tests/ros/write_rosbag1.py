#!/usr/bin/python3
"""A ROS 1 bag from a recording's messages (log_to_json.py's JSON lines), written with Debian's
python3-rosbag and the ROS 1 message classes, never agvcal's own code.

    write_rosbag1.py MESSAGES.jsonl MAPPING.json OUT.bag [none|bz2|lz4]

MAPPING.json as for write_bags.mjs. Record times are the header stamps plus a latency of
each topic's own, as there.
"""
import json
import math
import sys

import rosbag
import rospy
from geometry_msgs.msg import TransformStamped, TwistStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu, JointState, LaserScan
from tf2_msgs.msg import TFMessage

LATENCY_MS = {"/joint_states": 2, "/scan": 15}


def num(v):
    return float(v) if isinstance(v, str) else v


def stamp(utime):
    return rospy.Time(utime // 1000000, (utime % 1000000) * 1000)


def convert(m, mapping):
    if m["channel"] == "WHEELS":
        msg = JointState()
        steer = mapping.get("steer_joints") or {}
        for i, wheel in enumerate(m["name"]):
            msg.name.append(mapping["wheel_joints"][wheel])
            msg.position.append(num(m["position"][i]))
            msg.velocity.append(num(m["velocity"][i]))
            if wheel in steer:
                msg.name.append(steer[wheel])
                msg.position.append(num(m["steer"][i]))
                msg.velocity.append(0.0)
        if all(math.isnan(v) for v in msg.velocity):
            msg.velocity = []
        return "/joint_states", msg, ""
    if m["channel"] == "SCAN":
        msg = LaserScan()
        for field in ("angle_min", "angle_increment", "time_increment", "scan_time", "range_min",
                      "range_max"):
            setattr(msg, field, m[field])
        msg.ranges = [num(r) for r in m["ranges"]]
        msg.intensities = [num(i) for i in m["intensities"]]
        msg.angle_max = m["angle_min"] + m["angle_increment"] * (len(msg.ranges) - 1)
        return "/scan", msg, mapping["scan_frame"]
    if m["channel"] == "POSE":
        msg = Odometry()
        msg.child_frame_id = "base_link"
        msg.pose.pose.position.x, msg.pose.pose.position.y = m["x"], m["y"]
        msg.pose.pose.orientation.z = math.sin(m["theta"] / 2)
        msg.pose.pose.orientation.w = math.cos(m["theta"] / 2)
        cov, idx = [0.0] * 36, (0, 1, 5)
        for r in range(3):
            for c in range(3):
                cov[6 * idx[r] + idx[c]] = m["cov"][3 * r + c]
        msg.pose.covariance = cov
        return "/odom", msg, "odom"
    if m["channel"] == "IMU":
        msg = Imu()
        msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = m["angular_velocity"]
        a = m["linear_acceleration"]
        msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = a
        return mapping.get("imu_topic", "/imu"), msg, "imu"
    if m["channel"] == "DRIVE_CMD" and m["mode"] == 0:
        msg = TwistStamped()
        msg.twist.linear.x, msg.twist.linear.y, msg.twist.angular.z = m["vx"], m["vy"], m["omega"]
        return "/cmd_vel", msg, "base_link"
    return None


def main():
    source, mapping_path, out = sys.argv[1:4]
    compression = sys.argv[4] if len(sys.argv) > 4 else "none"
    mapping = json.load(open(mapping_path))
    first = True
    with rosbag.Bag(out, "w", compression=compression) as bag, open(source) as f:
        for line in f:
            m = json.loads(line)
            if first and mapping.get("lidar2d"):
                l = mapping["lidar2d"]
                t = TransformStamped()
                t.header.stamp, t.header.frame_id = stamp(m["utime"]), "base_link"
                t.child_frame_id = mapping["scan_frame"]
                t.transform.translation.x, t.transform.translation.y = l["x"], l["y"]
                t.transform.translation.z = 0.3
                t.transform.rotation.z, t.transform.rotation.w = math.sin(l["yaw"] / 2), math.cos(l["yaw"] / 2)
                bag.write("/tf_static", TFMessage(transforms=[t]), stamp(m["utime"] + 5000))
            first = False
            converted = convert(m, mapping)
            if converted is None:
                continue
            topic, msg, frame = converted
            if hasattr(msg, "header"):
                msg.header.stamp, msg.header.frame_id = stamp(m["utime"]), frame
            bag.write(topic, msg, stamp(m["utime"] + 1000 * LATENCY_MS.get(topic, 5)))


if __name__ == "__main__":
    main()
