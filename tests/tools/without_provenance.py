#!/usr/bin/env python3
"""Prints FILE without what says which run produced it (libcalib io/provenance.h): the
`provenance` object of a RESULT.json or REPORT.json, the provenance lines of a written robot file
or summary.txt. Two runs of the same calibration (live and offline, a bag and its direct import)
then compare byte for byte.

    without_provenance.py FILE
"""
import json
import re
import sys

KEYS = ("command", "directory", "robot_name", "robot_file", "recording", "recording_sha256",
        "agvcal_version", "date")
LINE = re.compile(r"^#?\s*(%s): " % "|".join(KEYS))

text = open(sys.argv[1]).read()
if text.lstrip().startswith("{"):
    result = json.loads(text)
    result.pop("provenance", None)
    print(json.dumps(result, indent=1))
else:
    sys.stdout.write("".join(l for l in text.splitlines(True) if not LINE.match(l)))
