"""An independent reader of the LCM log format for the integration tests (not our C++ code):
each event is magic 0xEDA1DA01, eventnum i64, timestamp i64, channel length u32, data length u32
(big-endian), then the channel and the data."""
import struct

MAGIC = 0xEDA1DA01


def parse(data):
    """(channel, timestamp, data) for every complete event of DATA from its start; stops at the
    first damaged or cut event. Returns (events, bytes_read)."""
    out, i = [], 0
    while i + 28 <= len(data):
        magic, _, ts, cl, dl = struct.unpack('>IqqII', data[i:i + 28])
        if magic != MAGIC or i + 28 + cl + dl > len(data):
            break
        out.append((data[i + 28:i + 28 + cl].decode('latin-1'), ts,
                    data[i + 28 + cl:i + 28 + cl + dl]))
        i += 28 + cl + dl
    return out, i


def events(path):
    """parse() of the file at PATH. Returns (events, bytes_read, file_size)."""
    data = open(path, 'rb').read()
    out, i = parse(data)
    return out, i, len(data)


def garbage(n, seed=1):
    """n bytes of seeded pseudo-random garbage (deterministic, unlike /dev/urandom)."""
    import random
    rng = random.Random(seed)
    return bytes(rng.getrandbits(8) for _ in range(n))


if __name__ == '__main__':
    # python3 lcm_log.py garbage N: N bytes of garbage on stdout (for the shell tests).
    import sys
    if len(sys.argv) == 3 and sys.argv[1] == 'garbage':
        sys.stdout.buffer.write(garbage(int(sys.argv[2])))
