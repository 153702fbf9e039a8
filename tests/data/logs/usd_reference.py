#!/usr/bin/python3
"""Independent reference for the Crazyflie uSD reader test (tests/test_logs.cpp):
parses the real logs of ../shared/data/crazyflie-usd/ with Python's struct and
zlib.crc32 (format in that folder's README.md) and prints, per file and event,
the record count, first/last timestamp and the largest interval. Run:
  /usr/bin/python3 tests/data/logs/usd_reference.py ../shared/data/crazyflie-usd
"""
import struct
import sys
import zlib
from pathlib import Path

SIZES = {'f': 4, 'i': 4, 'I': 4, 'h': 2, 'H': 2, 'b': 1, 'B': 1}


def parse(data, values=False):
    """(version, crc, {event id: (name, struct format, timestamps)}); with
    values=True each event also carries its variable names and its records
    (timestamp first, then the variables), as (name, fmt, timestamps, names, rows)."""
    body, crc = data[:-4], struct.unpack('<I', data[-4:])[0]
    assert zlib.crc32(body) == crc, 'CRC mismatch'
    assert body[0] == 0xBC
    version, n = struct.unpack_from('<HH', body, 1)
    pos = 5
    events = {}
    for _ in range(n):
        eid, = struct.unpack_from('<H', body, pos)
        pos += 2
        end = body.index(b'\0', pos)
        name = body[pos:end].decode()
        pos = end + 1
        nv, = struct.unpack_from('<H', body, pos)
        pos += 2
        fmt, names = '<', []
        for _ in range(nv):
            end = body.index(b'\0', pos)
            text = body[pos:end].decode()  # "name(T)"
            fmt += text[-2]
            names.append(text[:-3])
            pos = end + 1
        events[eid] = (name, fmt, [], names, [])
    tfmt = '<I' if version == 1 else '<Q'
    while pos < len(body):
        eid, = struct.unpack_from('<H', body, pos)
        pos += 2
        t, = struct.unpack_from(tfmt, body, pos)
        pos += struct.calcsize(tfmt)
        name, fmt, ts, _, rows = events[eid]
        ts.append(t)
        if values:
            rows.append((t,) + struct.unpack_from(fmt, body, pos))
        pos += struct.calcsize(fmt)
    if not values:
        events = {k: v[:3] for k, v in events.items()}
    return version, crc, events


if __name__ == '__main__':
    for f in sorted(Path(sys.argv[1]).glob('jana*')):
        version, crc, events = parse(f.read_bytes())
        for eid, (name, fmt, ts) in events.items():
            gaps = max(b - a for a, b in zip(ts, ts[1:]))
            print(f'{f.name} v{version} crc {crc:08x} {name}: {len(ts)} records, '
                  f't {ts[0]}..{ts[-1]} us, largest interval {gaps} us')
