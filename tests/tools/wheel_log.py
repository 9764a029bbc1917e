#!/usr/bin/env python3
"""Writes a copy of an lcm-logger recording with one WHEELS message (wheel_state_t) changed,
for the hostile-input tests:
  wheel_log.py IN.log OUT.log N position WHEEL DELTA   adds DELTA (rad, or nan/inf) to WHEEL's position
  wheel_log.py IN.log OUT.log N utime DELTA            adds DELTA (us) to the stamp
N is 1-based among the WHEELS messages; WHEEL is a name as in the message. The message keeps its
length, so the log's framing is untouched."""
import struct
import sys


def wheel_fields(msg):
    """Offsets of utime and of each wheel's position in an encoded wheel_state_t (after the hash)."""
    pos = 8 + 8
    (num,) = struct.unpack_from('>i', msg, pos)
    pos += 4
    names = []
    for _ in range(num):
        (n,) = struct.unpack_from('>i', msg, pos)
        names.append(bytes(msg[pos + 4:pos + 4 + n - 1]).decode())
        pos += 4 + n
    return 8, {name: pos + 8 * i for i, name in enumerate(names)}


def main():
    src, dst, nth, field = sys.argv[1:5]
    nth = int(nth)
    data = bytearray(open(src, 'rb').read())
    pos, seen = 0, 0
    while pos + 28 <= len(data):
        _, _, _, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
        start = pos + 28 + channel_len
        if data[pos + 28:start].decode() == 'WHEELS':
            seen += 1
            if seen == nth:
                msg = memoryview(data)[start:start + data_len]
                utime_at, positions = wheel_fields(msg)
                if field == 'utime':
                    (utime,) = struct.unpack_from('>q', msg, utime_at)
                    struct.pack_into('>q', msg, utime_at, utime + int(sys.argv[5]))
                else:
                    at = positions[sys.argv[5]]
                    (value,) = struct.unpack_from('>d', msg, at)
                    struct.pack_into('>d', msg, at, value + float(sys.argv[6]))
                del msg
                open(dst, 'wb').write(data)
                return 0
        pos = start + data_len
    sys.exit(f'{src}: fewer than {nth} messages on WHEELS')


if __name__ == '__main__':
    sys.exit(main())
