#!/usr/bin/env python3
"""An agvcal recording (LCM log) as JSON lines, one message each, for write_bags.mjs.

    log_to_json.py LCMTYPES_PY_DIR RECORDING.log > MESSAGES.jsonl

Decoded with the Python types lcm-gen makes from lcmtypes/ (LCMTYPES_PY_DIR: `lcm-gen -p`'s
output) and the LCM log format read here, so nothing of agvcal's C++ is involved.
Non-finite numbers become the strings "NaN", "Infinity", "-Infinity" (JSON has none).
"""
import json
import math
import os
import sys

sys.path.insert(0, sys.argv[1])
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from lcm_log import events  # noqa: E402
from agvcal import drive_command_t, imu_t, laser_scan_t, pose2d_t, wheel_state_t  # noqa: E402

TYPES = {"WHEELS": wheel_state_t, "SCAN": laser_scan_t, "POSE": pose2d_t, "IMU": imu_t,
         "DRIVE_CMD": drive_command_t}


def plain(value):
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def main():
    out = sys.stdout
    for channel, data in events(sys.argv[2]):
        if channel not in TYPES:
            continue
        message = TYPES[channel].decode(data)
        record = {"channel": channel}
        record.update({field: plain(getattr(message, field)) for field in message.__slots__})
        out.write(json.dumps(record) + "\n")


if __name__ == "__main__":
    try:
        main()
    except BrokenPipeError:  # the reader took what it wanted (head)
        sys.stderr.close()
