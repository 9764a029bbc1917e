#!/usr/bin/env python3
"""Writes a copy of an lcm-logger recording with one 32-bit big-endian field of one message
overwritten, for the hostile-input tests:
  corrupt_log.py IN.log OUT.log CHANNEL N OFFSET VALUE
overwrites, in the N-th message (1-based) on CHANNEL, the 4 bytes at OFFSET of its encoded
message (after lcm-gen's 8-byte type hash at 0) with VALUE (decimal or 0x...).
  corrupt_log.py IN.log OUT.log CHANNEL all OFFSET +DELTA
adds DELTA to the 64-bit big-endian field at OFFSET of every message on CHANNEL (e.g. OFFSET 8,
the utime after the hash: a stream stamped on another clock).
  corrupt_log.py IN.log OUT.log CHANNEL all OFFSET =VALUE
overwrites the 32-bit field at OFFSET of every message on CHANNEL with VALUE (e.g. SCAN all 20
=0x7fc00000: every scan's angle_increment NaN)."""
import struct
import sys


def change_all(data, dst, channel, offset, change):
    """Applies change(data, at) at OFFSET of every message on channel."""
    pos = 0
    while pos + 28 <= len(data):
        _, _, _, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
        if data[pos + 28:pos + 28 + channel_len].decode() == channel:
            change(data, pos + 28 + channel_len + offset)
        pos += 28 + channel_len + data_len
    open(dst, 'wb').write(data)
    return 0


def shift_all(data, dst, channel, offset, delta):
    return change_all(data, dst, channel, offset,
                      lambda d, at: struct.pack_into('>q', d, at, struct.unpack_from('>q', d, at)[0] + delta))


def set_all(data, dst, channel, offset, value):
    return change_all(data, dst, channel, offset, lambda d, at: struct.pack_into('>I', d, at, value))


def main():
    src, dst, channel, nth, offset, value = sys.argv[1:7]
    data = bytearray(open(src, 'rb').read())
    if nth == 'all' and value.startswith('='):
        return set_all(data, dst, channel, int(offset), int(value[1:], 0))
    if nth == 'all':
        return shift_all(data, dst, channel, int(offset), int(value))
    nth, offset, value = int(nth), int(offset), int(value, 0) & 0xffffffff
    pos, seen = 0, 0
    while pos + 28 <= len(data):
        _, _, _, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
        name = data[pos + 28:pos + 28 + channel_len].decode()
        if name == channel:
            seen += 1
            if seen == nth:
                struct.pack_into('>I', data, pos + 28 + channel_len + offset, value)
                open(dst, 'wb').write(data)
                return 0
        pos += 28 + channel_len + data_len
    sys.exit(f'{src}: fewer than {nth} messages on {channel}')


if __name__ == '__main__':
    sys.exit(main())
