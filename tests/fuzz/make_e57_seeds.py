#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Writes the e57_fuzzer seed corpus: small E57 files (pages with CRC-32C, XML, data packets)
with a posed cartesian scan of doubles, and a gridded scan of bit-packed scaled integers with an
invalid state and intensity. Run from anywhere."""
import pathlib
import struct

OUT = pathlib.Path(__file__).resolve().parent / "corpus" / "e57_fuzzer"
PAGE, PAYLOAD = 1024, 1020


def crc32c(data):
    crc = 0xFFFFFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF


def physical(logical):
    return logical // PAYLOAD * PAGE + logical % PAYLOAD


def packed(values, minimum, bits):
    number, shift = 0, 0
    for v in values:
        number |= (v - minimum) << shift
        shift += bits
    return number.to_bytes((shift + 7) // 8, "little")


def section(streams, at):
    lengths = b"".join(struct.pack("<H", len(s)) for s in streams)
    body = struct.pack("<BBHH", 1, 0, 0, len(streams)) + lengths + b"".join(streams)
    body += b"\0" * (-len(body) % 4)
    body = body[:2] + struct.pack("<H", len(body) - 1) + body[4:]
    header = struct.pack("<B7xQQQ", 1, 32 + len(body), physical(at + 32), 0)
    return header + body


def e57(scans):
    logical = bytearray(48)
    children = ""
    for name, pose, prototype, streams, count in scans:
        at = len(logical)
        logical += section(streams, at)
        children += (f'<vectorChild type="Structure"><name type="String"><![CDATA[{name}]]></name>'
                     f'{pose}<points type="CompressedVector" fileOffset="{physical(at)}" '
                     f'recordCount="{count}"><prototype type="Structure">{prototype}</prototype>'
                     f'<codecs type="Vector"/></points></vectorChild>')
    xml = ('<?xml version="1.0" encoding="UTF-8"?><e57Root type="Structure" '
           'xmlns="http://www.astm.org/COMMIT/E57/2010-e57-v1.0">'
           f'<data3D type="Vector">{children}</data3D></e57Root>').encode()
    xml_at = len(logical)
    logical += xml
    logical += b"\0" * (-len(logical) % PAYLOAD)
    logical[:48] = b"ASTM-E57" + struct.pack("<IIQQQQ", 1, 0, len(logical) // PAYLOAD * PAGE,
                                             physical(xml_at), len(xml), PAGE)
    out = bytearray()
    for p in range(0, len(logical), PAYLOAD):
        chunk = bytes(logical[p:p + PAYLOAD])
        out += chunk + struct.pack(">I", crc32c(chunk))
    return bytes(out)


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    pose = ('<pose type="Structure"><rotation type="Structure"><w type="Float">1</w>'
            '<x type="Float"/><y type="Float"/><z type="Float"/></rotation>'
            '<translation type="Structure"><x type="Float">1</x><y type="Float">2</y>'
            '<z type="Float">3</z></translation></pose>')
    xs = [0.1 * i for i in range(20)]
    doubles = [struct.pack("<20d", *v) for v in (xs, xs[::-1], [0.5] * 20)]
    proto = ''.join(f'<cartesian{a} type="Float"/>' for a in "XYZ")
    (OUT / "posed_doubles.e57").write_bytes(e57([("posed", pose, proto, doubles, 20)]))

    rows = [r for c in range(4) for r in range(5)]
    cols = [c for c in range(4) for r in range(5)]
    grid = [packed([r * 100 for r in rows], 0, 10), packed([c * 100 for c in cols], 0, 10),
            packed([7] * 20, 0, 10), packed([0] * 19 + [1], 0, 1),
            struct.pack("<20f", *[0.5] * 20), packed(rows, 0, 3), packed(cols, 0, 2)]
    proto = (''.join(f'<cartesian{a} type="ScaledInteger" minimum="0" maximum="1000" '
                     f'scale="0.01"/>' for a in "XYZ")
             + '<cartesianInvalidState type="Integer" minimum="0" maximum="1"/>'
             + '<intensity type="Float" precision="single"/>'
             + '<rowIndex type="Integer" minimum="0" maximum="4"/>'
             + '<columnIndex type="Integer" minimum="0" maximum="3"/>')
    (OUT / "grid_scaled.e57").write_bytes(e57([("grid", "", proto, grid, 20)]))


if __name__ == "__main__":
    main()
