#!/usr/bin/env python3
"""The Python half of tests/lcm/lcm_types.sh: every event of an LCM log, decoded with the Python
types `lcm-gen -p` makes (build/lcmtypes-py; they need only `struct`), found by fingerprint,
printed as `CHANNEL TEXT` in the canonical text of tests/lcm/message_text.h.

    lcm_log_text.py LCMTYPES_PY_DIR LOG
"""
import importlib
import math
import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), '..', 'ros'))
from lcm_log import events  # noqa: E402


def types_by_fingerprint(py_dir):
    sys.path.insert(0, py_dir)
    types = {}
    for name in sorted(os.listdir(os.path.join(py_dir, 'agvcal'))):
        if name.endswith('.py') and name != '__init__.py':
            module = importlib.import_module('agvcal.' + name[:-3])
            cls = getattr(module, name[:-3])
            types[cls._get_packed_fingerprint()] = cls
    return types


def text(value):
    if isinstance(value, (list, tuple)):
        return '[' + ','.join(text(v) for v in value) + ']'
    if isinstance(value, float):
        return 'nan' if math.isnan(value) else struct.pack('>d', value).hex()
    if isinstance(value, str):
        return '"' + value.encode('utf-8').hex() + '"'
    return str(int(value))  # bool too: 1/0


def main():
    types = types_by_fingerprint(sys.argv[1])
    out = []
    for channel, data in events(sys.argv[2]):
        cls = types.get(data[:8])
        if cls is None:
            out.append(f'{channel} unknown')
            continue
        message = cls.decode(data)
        fields = ' '.join(f'{name}={text(getattr(message, name))}' for name in sorted(message.__slots__))
        out.append(f'{channel} agvcal.{cls.__name__} {fields}')
    sys.stdout.write(''.join(line + '\n' for line in out))


if __name__ == '__main__':
    main()
