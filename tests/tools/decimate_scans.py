#!/usr/bin/env python3
"""Writes a copy of an lcm-logger recording that keeps only every Nth message on one channel
(default SCAN), every other channel untouched: a low-rate recording (scans 2-5 Hz, large motion
between them) made from a real one, whose scans and odometry are otherwise exactly the recorded
ones (docs/calibration.md, "Low-rate recordings"):
  decimate_scans.py IN.log OUT.log N [FIRST] [CHANNEL]
keeps the messages numbered FIRST, FIRST + N, ... (0-based, FIRST defaults to 0)."""
import sys

from shift_scan_stamps import channel_events


def main():
    if len(sys.argv) < 4 or sys.argv[1] in ('-h', '--help'):
        print(__doc__)
        return 0 if len(sys.argv) > 1 and sys.argv[1] in ('-h', '--help') else 2
    src, dst, every = sys.argv[1], sys.argv[2], int(sys.argv[3])
    first = int(sys.argv[4]) if len(sys.argv) > 4 else 0
    channel = sys.argv[5] if len(sys.argv) > 5 else 'SCAN'
    if every < 1 or first < 0:
        sys.exit(f'N must be >= 1 and FIRST >= 0 (got {every}, {first})')
    data = open(src, 'rb').read()
    events = list(channel_events(data, src, channel))
    if not events:
        sys.exit(f'{src}: no message on {channel}')
    dropped = {event for k, (event, _) in enumerate(events) if k < first or (k - first) % every}
    out = bytearray()
    pos = 0
    while pos + 28 <= len(data):
        channel_len = int.from_bytes(data[pos + 20:pos + 24], 'big')
        data_len = int.from_bytes(data[pos + 24:pos + 28], 'big')
        end = pos + 28 + channel_len + data_len
        if pos not in dropped:
            out += data[pos:end]
        pos = end
    open(dst, 'wb').write(out)
    print(f'{dst}: kept {len(events) - len(dropped)} of {len(events)} messages on {channel}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
