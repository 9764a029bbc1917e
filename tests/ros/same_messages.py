#!/usr/bin/env python3
"""Exit 0 when two recordings' messages (log_to_json.py's JSON lines) of CHANNELS are the same:
equal fields, in time order (among equal stamps by channel: the order of messages with one
stamp is the importer's convention), WHEELS positions compared as increments from the first
message (importers count them from 0), DRIVE_CMD: body twists only (a Twist carries no stop or
wheel setpoints), without seq and timeout (a bag has neither).

    same_messages.py A.jsonl B.jsonl CHANNEL...
"""
import json
import sys


def messages(path, channels):
    out, first = [], {}
    for line in open(path):
        m = json.loads(line)
        if m["channel"] not in channels:
            continue
        if m["channel"] == "WHEELS":
            first.setdefault("WHEELS", m["position"])
            m["position"] = [p - p0 for p, p0 in zip(m["position"], first["WHEELS"])]
        if m["channel"] == "DRIVE_CMD":
            if m["mode"] != 0:
                continue
            m.pop("seq")
            m.pop("timeout")
        out.append(m)
    return sorted(out, key=lambda m: (m["utime"], m["channel"]))


def main():
    channels = set(sys.argv[3:])
    a, b = messages(sys.argv[1], channels), messages(sys.argv[2], channels)
    if len(a) != len(b):
        sys.exit(f"{len(a)} messages vs {len(b)}")
    for i, (x, y) in enumerate(zip(a, b)):
        if x != y:
            keys = [k for k in x if x.get(k) != y.get(k)]
            sys.exit(f"message {i} ({x['channel']} at {x['utime']}): {keys} differ")


if __name__ == "__main__":
    main()
