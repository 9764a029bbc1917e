#!/usr/bin/env python3
"""Writes a copy of an lcm-logger recording whose scans on one channel (default SCAN) declare no
beam timing: laser_scan_t's time_increment and scan_time (spec/messages.md) set to 0, as a device
that does not report them (issue 16, docs/mismatch.md "Time offsets: injected into real
recordings"). Nothing else changes, so the truth of the injection is exact: the scans' beams were
taken when they were, and only what the recording says about it is gone.
  drop_beam_timing.py IN.log OUT.log [CHANNEL]
Prints how many scans carried timing before."""
import struct
import sys

from shift_scan_stamps import channel_events


def main():
    if len(sys.argv) < 3 or sys.argv[1] in ('-h', '--help'):
        print(__doc__)
        return 0 if len(sys.argv) > 1 and sys.argv[1] in ('-h', '--help') else 2
    src, dst = sys.argv[1], sys.argv[2]
    channel = sys.argv[3] if len(sys.argv) > 3 else 'SCAN'
    data = bytearray(open(src, 'rb').read())
    scans, per_beam, period = 0, 0, 0
    for _, body in channel_events(data, src, channel):
        # hash (8), utime (8), angle_min (4), angle_increment (4), time_increment (4), scan_time (4)
        time_increment, scan_time = struct.unpack_from('>ff', data, body + 24)
        per_beam += time_increment != 0.0
        period += scan_time != 0.0
        struct.pack_into('>ff', data, body + 24, 0.0, 0.0)
        scans += 1
    if scans == 0:
        sys.exit(f'{src}: no message on {channel}')
    open(dst, 'wb').write(data)
    print(f'{dst}: {scans} scans on {channel}; {per_beam} carried a time_increment and {period} a scan_time; now none does')
    return 0


if __name__ == '__main__':
    sys.exit(main())
