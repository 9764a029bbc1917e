#!/usr/bin/env python3
"""Writes a copy of an lcm-logger recording with every message on one channel (default SCAN)
stamped later by a known offset: an injected sensor-to-wheel time offset whose truth is exact
(issue 16, docs/mismatch.md "Injected offsets on real recordings"):
  shift_scan_stamps.py IN.log OUT.log OFFSET_S [CHANNEL]
adds OFFSET_S (seconds, may be negative) to the message's utime (the int64 after lcm-gen's
8-byte type hash: laser_scan_t, pose2d_t) and to the logger's event timestamp. A scan stamped t
then reads t + OFFSET_S, so the time offset of spec/effects.md grows by OFFSET_S."""
import struct
import sys


def channel_events(data, src, channel):
    """(event offset, message body offset) of every event on `channel` of an lcm-logger
    recording's bytes; exits naming `src` and the byte where the framing breaks."""
    pos = 0
    while pos + 28 <= len(data):
        sync, _, _, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
        if sync != 0xEDA1DA01:
            sys.exit(f'{src}: byte {pos}: not an lcm-logger event (sync word {sync:#x})')
        if data[pos + 28:pos + 28 + channel_len].decode() == channel:
            yield pos, pos + 28 + channel_len
        pos += 28 + channel_len + data_len


def main():
    if len(sys.argv) < 4 or sys.argv[1] in ('-h', '--help'):
        print(__doc__)
        return 0 if len(sys.argv) > 1 and sys.argv[1] in ('-h', '--help') else 2
    src, dst, offset_s = sys.argv[1], sys.argv[2], float(sys.argv[3])
    channel = sys.argv[4] if len(sys.argv) > 4 else 'SCAN'
    shift_us = int(round(offset_s * 1e6))
    data = bytearray(open(src, 'rb').read())
    shifted = 0
    for event, body in channel_events(data, src, channel):
        (stamp,) = struct.unpack_from('>q', data, event + 12)
        struct.pack_into('>q', data, event + 12, stamp + shift_us)
        (utime,) = struct.unpack_from('>q', data, body + 8)
        struct.pack_into('>q', data, body + 8, utime + shift_us)
        shifted += 1
    if shifted == 0:
        sys.exit(f'{src}: no message on {channel}')
    open(dst, 'wb').write(data)
    print(f'{dst}: {shifted} messages on {channel} stamped {offset_s:+.6f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
