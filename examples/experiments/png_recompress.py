#!/usr/bin/env python3
"""Recompresses PNG files in place (zlib level 9, same pixels): gatcore's PNG
writer stores raw deflate blocks so it needs no zlib; pictures meant for the
repository are recompressed with this (standard library only). Atomic per file."""
import os
import struct
import sys
import zlib


def chunks(data, path):
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG file")
    i = 8
    while i < len(data):
        if i + 8 > len(data):
            raise SystemExit(f"{path}: truncated chunk header at byte {i}")
        (n,) = struct.unpack(">I", data[i:i + 4])
        kind = data[i + 4:i + 8]
        if i + 12 + n > len(data):
            raise SystemExit(f"{path}: truncated {kind!r} chunk at byte {i}")
        yield kind, data[i + 8:i + 8 + n]
        i += 12 + n


def chunk(kind, body):
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


def recompress(path):
    data = open(path, "rb").read()
    head, idat, rest = [], b"", []
    for kind, body in chunks(data, path):
        if kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
        elif not idat:
            head.append((kind, body))
        else:
            rest.append((kind, body))
    raw = zlib.decompress(idat)
    out = b"\x89PNG\r\n\x1a\n" + b"".join(chunk(k, b) for k, b in head)
    out += chunk(b"IDAT", zlib.compress(raw, 9)) + b"".join(chunk(k, b) for k, b in rest) + chunk(b"IEND", b"")
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(out)
    os.replace(tmp, path)
    return len(data), len(out)


if __name__ == "__main__":
    before = after = 0
    for p in sys.argv[1:]:
        a, b = recompress(p)
        before, after = before + a, after + b
    print(f"png_recompress: {len(sys.argv) - 1} files, {before} -> {after} bytes")
