#!/usr/bin/env python3
"""Re-encodes 8-bit RGB PNGs in place the way gatcore's write_png now does
(per-row adaptive filter: the smallest sum of absolute signed bytes, then
zlib level 9), same pixels, atomic per file. For pictures written before
write_png compressed (docs/img, docs/results). Standard library only."""
import os
import struct
import sys
import zlib


def chunks(data, path):
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG file")
    i = 8
    while i + 12 <= len(data):
        (n,) = struct.unpack(">I", data[i:i + 4])
        yield data[i + 4:i + 8], data[i + 8:i + 8 + n]
        i += 12 + n


def chunk(kind, body):
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


def paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else b if pb <= pc else c


def unfilter(raw, w, h):
    stride = 3 * w
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f = raw[y * (stride + 1)]
        cur = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = cur[i - 3] if i >= 3 else 0
            b = prev[i]
            c = prev[i - 3] if i >= 3 else 0
            pred = (0, a, b, (a + b) // 2, paeth(a, b, c))[f]
            cur[i] = (cur[i] + pred) & 0xFF
        rows.append(cur)
        prev = cur
    return rows


def refilter(rows, w):
    stride = 3 * w
    out, prev = bytearray(), bytearray(stride)
    for cur in rows:
        best = None
        for f in range(5):
            cand = bytearray(stride)
            for i in range(stride):
                a = cur[i - 3] if i >= 3 else 0
                b = prev[i]
                c = prev[i - 3] if i >= 3 else 0
                pred = (0, a, b, (a + b) // 2, paeth(a, b, c))[f]
                cand[i] = (cur[i] - pred) & 0xFF
            cost = sum(v if v < 128 else 256 - v for v in cand)
            if best is None or cost < best[0]:
                best = (cost, f, cand)
        out.append(best[1])
        out += best[2]
        prev = cur
    return bytes(out)


def main(paths):
    before = after = 0
    for path in paths:
        data = open(path, "rb").read()
        ihdr, idat, other = None, b"", []
        for kind, body in chunks(data, path):
            if kind == b"IHDR":
                ihdr = body
            elif kind == b"IDAT":
                idat += body
        w, h, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", ihdr)
        if depth != 8 or colour != 2 or interlace:
            print(f"{path}: not 8-bit RGB non-interlaced, left alone")
            continue
        rows = unfilter(zlib.decompress(idat), w, h)
        z = zlib.compress(refilter(rows, w), 9)
        png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", z) + chunk(b"IEND", b"")
        if len(png) < len(data):
            tmp = path + ".tmp"
            open(tmp, "wb").write(png)
            os.replace(tmp, path)
        before += len(data)
        after += min(len(png), len(data))
    print(f"{len(paths)} files, {before} -> {after} bytes")


main(sys.argv[1:])
