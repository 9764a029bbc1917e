#!/usr/bin/env python3
"""Writes a copy of an lcm-logger recording with a longitudinal slip written into the wheels
(a reproduction helper for the diagnosis's look-alike selection; scripts/ holds the full
injection suite):
  inject_slip.py IN.log OUT.log SLIP RADIUS
Every WHEELS step's travel grows by SLIP (v1^2 - v0^2) / 2, the integral of SLIP a v (to first
order omega / (1 - SLIP a)), as the same rotation added to each wheel so the turn is untouched:
SLIP in s^2/m, v the body's speed at the step's ends by central differences of the wheels' mean
rotation times RADIUS (m) over the samples within about +-50 ms (at least one), as the
diagnosis takes it (diagnose_fit.cc).
Messages keep their length, so the log's framing is untouched."""
import struct
import sys


def wheel_fields(msg):
    """Offset of utime and of each wheel's position in an encoded wheel_state_t (after the hash)."""
    pos = 8 + 8
    (num,) = struct.unpack_from('>i', msg, pos)
    pos += 4
    for _ in range(num):
        (n,) = struct.unpack_from('>i', msg, pos)
        pos += 4 + n
    return 8, [pos + 8 * i for i in range(num)]


def central(t, x):
    """d x / d t at each sample over k samples either side, k the samples in 50 ms (at least 1)."""
    n = len(t)
    k = max(1, round(0.05 / max((t[-1] - t[0]) / (n - 1), 1e-4)))
    out = []
    for i in range(n):
        lo, hi = max(0, i - k), min(n - 1, i + k)
        out.append((x[hi] - x[lo]) / (t[hi] - t[lo]))
    return out


def main():
    src, dst, slip, radius = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
    data = bytearray(open(src, 'rb').read())
    msgs, pos = [], 0
    while pos + 28 <= len(data):
        _, _, _, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
        start = pos + 28 + channel_len
        if data[pos + 28:start].decode() == 'WHEELS':
            msg = memoryview(data)[start:start + data_len]
            utime_at, positions = wheel_fields(msg)
            (utime,) = struct.unpack_from('>q', msg, utime_at)
            msgs.append((utime * 1e-6, [struct.unpack_from('>d', msg, p)[0] for p in positions], start, positions))
        pos = start + data_len
    if len(msgs) < 3:
        sys.exit(f'{src}: fewer than 3 messages on WHEELS')
    t = [m[0] for m in msgs]
    travel = [radius * sum(m[1]) / len(m[1]) for m in msgs]
    speed = central(t, travel)
    new = list(msgs[0][1])
    for i in range(len(msgs)):
        if i:
            step = [cur - prev for cur, prev in zip(msgs[i][1], msgs[i - 1][1])]
            extra = slip * (speed[i] ** 2 - speed[i - 1] ** 2) / 2 / radius
            new = [n + d + extra for n, d in zip(new, step)]
        for p, value in zip(msgs[i][3], new):
            struct.pack_into('>d', data, msgs[i][2] + p, value)
    open(dst, 'wb').write(data)
    return 0


if __name__ == '__main__':
    sys.exit(main())
