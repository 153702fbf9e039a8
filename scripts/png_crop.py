#!/usr/bin/python3
"""Crops a PNG (8-bit RGB or RGBA, as Chromium's --screenshot writes) without
imaging libraries: png_crop.py IN OUT TOP BOTTOM (pixel rows, the full width),
for the report screenshots of docs/report.md."""
import struct
import sys
import zlib

import numpy as np


def read_png(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, w = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and ctype in (2, 6), "8-bit RGB or RGBA only"
            ch = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = np.frombuffer(zlib.decompress(idat), dtype=np.uint8).reshape(h, 1 + w * ch)
    out = np.zeros((h, w * ch), dtype=np.int32)
    for y in range(h):  # undo the per-row filters (PNG spec, section 9)
        f, line = raw[y, 0], raw[y, 1:].astype(np.int32)
        prev = out[y - 1] if y else np.zeros(w * ch, dtype=np.int32)
        if f == 0:
            out[y] = line
        elif f == 1:
            r = line.copy()
            for i in range(ch, w * ch):
                r[i] = (r[i] + r[i - ch]) & 255
            out[y] = r
        elif f == 2:
            out[y] = (line + prev) & 255
        else:
            r = line.copy()
            for i in range(w * ch):
                a = r[i - ch] if i >= ch else 0
                b = prev[i]
                if f == 3:
                    r[i] = (r[i] + ((a + b) >> 1)) & 255
                else:
                    c = prev[i - ch] if i >= ch else 0
                    p = a + b - c
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                    r[i] = (r[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
            out[y] = r
    return out.astype(np.uint8).reshape(h, w, ch)


def write_png(path, img):
    h, w, ch = img.shape
    raw = b"".join(b"\x00" + img[y].tobytes() for y in range(h))
    chunk = lambda k, b: struct.pack(">I", len(b)) + k + b + struct.pack(">I", zlib.crc32(k + b) & 0xFFFFFFFF)
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2 if ch == 3 else 6, 0, 0, 0)
    open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) +
                           chunk(b"IEND", b""))


if __name__ == "__main__":
    src, dst, top, bottom = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    write_png(dst, read_png(src)[top:bottom])
