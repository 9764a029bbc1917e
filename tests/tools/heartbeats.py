#!/usr/bin/env python3
"""The HEARTBEAT states in an lcm-logger recording (which may be still being written: a torn
last event is left out), one line each, for the end-to-end tests' waits and checks:
  heartbeats.py LOG [PROCESS]
prints "PROCESS<TAB>STATE" per heartbeat, or with PROCESS only that process's states."""
import struct
import sys


def heartbeats(data):
    """(process, state) of every whole HEARTBEAT event in the recording `data`."""
    pos = 0
    while pos + 28 <= len(data):
        _, _, _, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
        start = pos + 28 + channel_len
        if start + data_len > len(data):
            return
        if data[pos + 28:start] == b'HEARTBEAT':
            at = start + 16  # after the type hash and utime
            strings = []
            for _ in range(2):  # process, then (after the pid) state
                (n,) = struct.unpack_from('>i', data, at)
                strings.append(data[at + 4:at + 4 + n - 1].decode(errors='replace'))
                at += 4 + n + 4
            yield strings[0], strings[1]
        pos = start + data_len


def main():
    try:
        data = open(sys.argv[1], 'rb').read()
    except FileNotFoundError:
        return 0
    for process, state in heartbeats(data):
        if len(sys.argv) < 3:
            print(f"{process}\t{state}")
        elif process == sys.argv[2]:
            print(state)
    return 0


if __name__ == '__main__':
    sys.exit(main())
