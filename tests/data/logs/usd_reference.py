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


def parse(data):
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
        fmt = '<'
        for _ in range(nv):
            end = body.index(b'\0', pos)
            fmt += body[pos:end].decode()[-2]
            pos = end + 1
        events[eid] = (name, fmt, [])
    tfmt = '<I' if version == 1 else '<Q'
    while pos < len(body):
        eid, = struct.unpack_from('<H', body, pos)
        pos += 2
        t, = struct.unpack_from(tfmt, body, pos)
        pos += struct.calcsize(tfmt)
        name, fmt, ts = events[eid]
        ts.append(t)
        pos += struct.calcsize(fmt)
    return version, crc, events


for f in sorted(Path(sys.argv[1]).glob('jana*')):
    version, crc, events = parse(f.read_bytes())
    for eid, (name, fmt, ts) in events.items():
        gaps = max(b - a for a, b in zip(ts, ts[1:]))
        print(f'{f.name} v{version} crc {crc:08x} {name}: {len(ts)} records, '
              f't {ts[0]}..{ts[-1]} us, largest interval {gaps} us')
