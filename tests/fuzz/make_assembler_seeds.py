#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Writes the assembler_fuzzer seed corpus: ProcessRequest streams in the fuzzer's framing (each
message a 2-byte little-endian length plus its serialized bytes), encoded from text format by
protoc. Run from anywhere; needs protoc on PATH."""
import math
import pathlib
import struct
import subprocess
import zlib

HERE = pathlib.Path(__file__).resolve().parent
PROTO_DIR = HERE.parent.parent / "proto"
OUT = HERE / "corpus" / "assembler_fuzzer"


def encode(text):
    return subprocess.run(
        ["protoc", f"--proto_path={PROTO_DIR}", "--encode=scanprep.v1.ProcessRequest",
         "scanprep/v1/scanprep.proto"],
        input=text.encode(), capture_output=True, check=True).stdout


def stream(*messages):
    out = b""
    for m in messages:
        data = encode(m)
        out += len(data).to_bytes(2, "little") + data
    return out


def end(points, crc32=0):
    """The end message; crc32 0 asks the fuzzer to fill in the chunks' CRC-32."""
    return "end { points: %d crc32: %d }" % (points, crc32)


def crc32_of(xyz, scanline=()):
    """The StreamEnd CRC-32 (scanprep.proto) of one chunk with xyz and scanline."""
    data = struct.pack("<%df" % len(xyz), *xyz) + struct.pack("<%dI" % len(scanline), *scanline)
    return zlib.crc32(data)


def floats(values):
    return "[" + ", ".join(f"{v:.4f}" for v in values) + "]"


def plane(rows, cols, step=0.5, wave=0.05):
    xyz, lines = [], []
    for r in range(rows):
        for c in range(cols):
            xyz += [c * step, r * step, wave * math.sin(c + 2 * r)]
            lines.append(r)
    return xyz, lines


def header_one(total_points):
    return ('header { unit: MILLIMETRE total_points: %d '
            'scans { scan_id: "a" scanline_spacing: 0.5 view_direction { z: 1 } } }' % total_points)


HEADER_TWO = ('header { unit: METRE scanner_kind: FLEXIBLE total_points: 8 '
              'scans { camera_position { z: 1 } } '
              'scans { to_common { rotation { z: 0.7071068 w: 0.7071068 } translation { x: 0.001 } } '
              'camera_position { x: 1 } } '
              'options { stages: "outliers" stages: "normals" stages: "measures" params { key: "outliers.k" value: "3" } } }')


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    xyz, lines = plane(6, 8)
    # xyz rounded as floats() prints them, so that the CRC is over the values protoc encodes.
    xyz = [float(f"{v:.4f}") for v in xyz]
    plane_crc = crc32_of(xyz, lines)
    seeds = {
        # The CRC-32 computed here, not by the fuzzer: the definition checked across languages.
        "plane_scanlines": stream(header_one(len(lines)),
                                  f"points {{ xyz: {floats(xyz)} scanline: {lines} }}",
                                  end(len(lines), plane_crc)),
        "two_scans_posed": stream(HEADER_TWO,
                                  f"points {{ xyz: {floats(xyz[:12])} scan_index: [0, 0, 1, 1] }}",
                                  f"points {{ xyz: {floats(xyz[12:24])} scan_index: [1, 0, 1, 0] }}",
                                  end(8)),
        "one_point": stream(header_one(1), "points { xyz: [1, 2, 3] }", end(1)),
        "duplicates_and_nan": stream(header_one(4),
                                     "points { xyz: [1, 1, 1, 1, 1, 1, 1, 1, 1, nan, 0, 0] "
                                     "quality: [1, 0.5, 0, 1] }", end(4)),
        "header_only": stream(header_one(1)),
        "points_first": stream("points { xyz: [0, 0, 0] }", header_one(1)),
        "bad_scan_index": stream(HEADER_TWO, "points { xyz: [0, 0, 0] scan_index: [7] }"),
        "no_end": stream(header_one(1), "points { xyz: [1, 2, 3] }"),
        "checksum_mismatch": stream(header_one(len(lines)),
                                    f"points {{ xyz: {floats(xyz)} scanline: {lines} }}",
                                    end(len(lines), plane_crc ^ 1)),
        "points_after_end": stream(header_one(2), "points { xyz: [1, 2, 3] }", end(1),
                                   "points { xyz: [4, 5, 6] }"),
    }
    for name, data in seeds.items():
        (OUT / name).write_bytes(data)


if __name__ == "__main__":
    main()
