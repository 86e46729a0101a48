#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Writes the las_fuzzer seed corpus: a LAS 1.2 file of point format 1 with two sweeps (the scan
direction flips, the last point of the first sweep on the flight line's edge) and a LAS 1.4 file
of point format 6 with extra bytes per record. Run from anywhere."""
import pathlib
import struct

OUT = pathlib.Path(__file__).resolve().parent / "corpus" / "las_fuzzer"
SIZES = [20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67]


def las(minor, fmt, points, extra=0):
    header = 375 if minor >= 4 else 227
    record = SIZES[fmt] + extra
    out = bytearray(header + len(points) * record)
    out[0:4] = b"LASF"
    out[24], out[25] = 1, minor
    struct.pack_into("<HIIBHI", out, 94, header, header, 0, fmt, record,
                     0 if minor >= 4 else len(points))
    if minor >= 4:
        struct.pack_into("<Q", out, 247, len(points))
    struct.pack_into("<6d", out, 131, 0.001, 0.001, 0.001, 10.0, 20.0, 30.0)
    for i, (x, y, z, direction, edge) in enumerate(points):
        at = header + i * record
        struct.pack_into("<iiiH", out, at, x, y, z, 100 * i)
        flags = (0x40 if direction else 0) | (0x80 if edge else 0)
        if fmt >= 6:
            out[at + 14], out[at + 15] = 0x11, flags
            struct.pack_into("<h", out, at + 18, -500 + 100 * i)
        else:
            out[at + 14], out[at + 16] = flags | 0x09, (i * 3) & 0x7F
    return bytes(out)


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    points = [(1000 * i, 50 * i, 7 * i, i >= 4, i == 3) for i in range(8)]
    (OUT / "v12_format1_sweeps.las").write_bytes(las(2, 1, points))
    (OUT / "v14_format6_extra.las").write_bytes(las(4, 6, points, extra=4))


if __name__ == "__main__":
    main()
