#!/usr/bin/env python3
"""Writes a copy of an lcm-logger recording with one 32-bit big-endian field of one message
overwritten, for the hostile-input tests:
  corrupt_log.py IN.log OUT.log CHANNEL N OFFSET VALUE
overwrites, in the N-th message (1-based) on CHANNEL, the 4 bytes at OFFSET of its encoded
message (after lcm-gen's 8-byte type hash at 0) with VALUE (decimal or 0x...).
  corrupt_log.py IN.log OUT.log CHANNEL all OFFSET +DELTA
adds DELTA to the 64-bit big-endian field at OFFSET of every message on CHANNEL (e.g. OFFSET 8,
the utime after the hash: a stream stamped on another clock)."""
import struct
import sys


def shift_all(data, dst, channel, offset, delta):
    pos = 0
    while pos + 28 <= len(data):
        _, _, _, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
        if data[pos + 28:pos + 28 + channel_len].decode() == channel:
            at = pos + 28 + channel_len + offset
            struct.pack_into('>q', data, at, struct.unpack_from('>q', data, at)[0] + delta)
        pos += 28 + channel_len + data_len
    open(dst, 'wb').write(data)
    return 0


def main():
    src, dst, channel, nth, offset, value = sys.argv[1:7]
    data = bytearray(open(src, 'rb').read())
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
