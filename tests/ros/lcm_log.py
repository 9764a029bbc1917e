"""The events of an LCM log (lcm-logger's format: a 28-byte header of sync word, event number,
time, channel and data lengths, then the channel and the data), read with `struct` alone so that
nothing of agvcal's C++ is involved."""
import struct

SYNC = 0xEDA1DA01


def events(path):
    """(channel, data) of every event of the log at `path`, in order."""
    with open(path, "rb") as f:
        while True:
            head = f.read(28)
            if not head:
                return
            sync, _, _, channel_len, data_len = struct.unpack(">IqqII", head)
            if sync != SYNC:
                raise SystemExit(f"{path}: not an LCM log")
            yield f.read(channel_len).decode(), f.read(data_len)
