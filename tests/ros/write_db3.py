#!/usr/bin/env python3
"""A rosbag2 SQLite3 bag from write_bags.mjs's serialized messages, with Python's sqlite3 and
rosbag2's table layout (storage schema version 3) and metadata.yaml.

    write_db3.py CDR.jsonl BAG_DIR
"""
import json
import os
import sqlite3
import sys

SCHEMA = """
CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL);
CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                    serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
                      data BLOB NOT NULL);
CREATE INDEX timestamp_idx ON messages (timestamp ASC);
"""


def main():
    source, bag = sys.argv[1], sys.argv[2]
    os.makedirs(bag, exist_ok=True)
    name = os.path.basename(os.path.normpath(bag)) + "_0.db3"
    db = sqlite3.connect(os.path.join(bag, name))
    db.executescript(SCHEMA)
    db.execute("INSERT INTO schema VALUES (3, 'humble')")
    topics, counts, times = {}, {}, []
    with open(source) as f:
        for line in f:
            m = json.loads(line)
            if m["topic"] not in topics:
                topics[m["topic"]] = (len(topics) + 1, m["type"])
                db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')",
                           (len(topics), m["topic"], m["type"]))
            counts[m["topic"]] = counts.get(m["topic"], 0) + 1
            times.append(int(m["record_ns"]))
            db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                       (topics[m["topic"]][0], int(m["record_ns"]), bytes.fromhex(m["data"])))
    db.commit()
    db.close()
    entries = "".join(
        f"    - topic_metadata:\n        name: {t}\n        type: {ty}\n"
        f"        serialization_format: cdr\n        offered_qos_profiles: ''\n"
        f"      message_count: {counts[t]}\n" for t, (_, ty) in topics.items())
    with open(os.path.join(bag, "metadata.yaml"), "w") as f:
        f.write("rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
                f"  duration:\n    nanoseconds: {max(times) - min(times)}\n"
                f"  starting_time:\n    nanoseconds_since_epoch: {min(times)}\n"
                f"  message_count: {len(times)}\n  topics_with_message_count:\n{entries}"
                f"  compression_format: ''\n  compression_mode: ''\n"
                f"  relative_file_paths:\n    - {name}\n")


if __name__ == "__main__":
    main()
