# SPDX-License-Identifier: Apache-2.0
"""Scan files as the `scanprep` CLI reads them (core/io/*.cc, docs/cli.md "File formats"): PLY
(ascii, binary little and big endian), PCD (ascii, binary, binary_compressed through the system's
liblzf), XYZ/ASC/TXT/PTS text, and scanalyze .conf poses.

The rules are the CLI's: a point with a NaN or infinite coordinate is a scanner's "no return",
left out and counted (Scan.points_unmeasured, a note); a file with no point left is an error; the
scan id is the file's stem, or STEM#VALUE per value of a PLY scan column; a PLY range_grid gives
each vertex its grid row as scanline, as does each image row of an organised PCD (HEIGHT > 1); a
PCD VIEWPOINT other than PCL's default is the scan's camera_position; double coordinates (PLY
double, PCD F8, text) stay float64, so the client sends them relative to a local origin as the
CLI does, float ones stay float32. Files carry no unit: pass process(unit=...) (the CLI assumes
millimetres; PCL writes PCD files in metres).

Every other per-point field of one value is kept in Scan.attributes, by the file's name, in the
file's type (native byte order), for the kept points only: PLY vertex properties (red, green,
blue, alpha, nx, any scalar), PCD fields (rgb and rgba as declared, label, curvature, normal_x,
...), the other columns a text file's "# columns:" line names (float64). A PLY vertex list
property, a PCD field of COUNT > 1 and an ascii value its declared type cannot hold are left out
with a note. Process() gives them back for the returned points (Result.attributes)."""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import os
import pathlib
import re
import struct
from typing import Mapping, Optional, Sequence, Union

import numpy as np

from scanprep_client.client import Scan

PathLike = Union[str, os.PathLike]
Pose = tuple[tuple[float, float, float, float], tuple[float, float, float]]

_TEXT_EXTENSIONS = (".xyz", ".asc", ".txt", ".pts")
_READABLE = ".ply, .pcd, .xyz, .asc, .txt, .pts"
_WHY = "no measurement (a NaN or infinite coordinate)"


def _split(line: bytes, commas: bool = False) -> list[bytes]:
    if commas:
        line = line.replace(b",", b" ")
    return line.split()


def _lines(data: bytes) -> list[bytes]:
    lines = data.split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    return lines


def _number(token: bytes) -> float:
    """A number as the C++ readers' ParseDouble (from_chars; a leading '+' allowed)."""
    text = token.decode("ascii", "replace")
    if text.lower().lstrip("+-") in ("nan", "inf", "infinity") or re.fullmatch(
            r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", text):
        return float(text)
    raise ValueError(text)


def _numbers(tokens: Sequence[bytes], what) -> np.ndarray:
    try:
        return np.array([_number(t) for t in tokens], dtype=np.float64)
    except ValueError as e:
        raise ValueError(f"{what()}: '{e}' is not a number") from None


class _Unmeasured:
    """Points without a position: counted, the first named in the file's terms."""

    def __init__(self, name: str, unit: str, finite: np.ndarray, labels=None):
        self.name = name
        self.count = int(np.count_nonzero(~finite))
        self.first = ""
        if self.count:
            k = int(np.flatnonzero(~finite)[0])
            self.first = f"{unit} {labels[k] if labels is not None else k}"

    def finish(self, kept: int, notes: Optional[list]) -> None:
        if kept == 0 and self.count == 0:
            raise ValueError(f"{self.name}: no points in the file")
        if kept == 0:
            raise ValueError(f"{self.name}: no points in the file: all {self.count} have {_WHY}; "
                             f"the first is {self.first}")
        if self.count and notes is not None:
            notes.append(f"{self.name}: {self.count} of {kept + self.count} points have {_WHY} "
                         f"and were left out; the first is {self.first}")


def _coordinates(xyz: np.ndarray, wide: bool, name: str) -> np.ndarray:
    """xyz (n×3, double) as the points to send: float32 unless the file held doubles; a finite
    value beyond float's range is an error, as in the C++ readers."""
    narrow = xyz.astype(np.float32)
    if not wide:
        bad = np.flatnonzero(np.any(np.isfinite(xyz) & ~np.isfinite(narrow), axis=1))
        if len(bad):
            raise ValueError(f"{name}: point {bad[0]}: coordinate beyond the range of a float")
        return narrow
    return xyz.astype(np.float64)


# ---------------------------------------------------------------------------------------- PLY

_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2",
              "int16": "i2", "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4",
              "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
              "float64": "f8"}
_STRUCT = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I", "f4": "f", "f8": "d"}
# Vertex properties the reader uses, by slot; where a file has several names of one slot the
# last in this order is used and the others are kept as attributes.
_PLY_SLOTS = {"scanline": ("scanline", "scanline_id", "row"), "quality": ("confidence", "quality"),
              "intensity": ("intensity",), "scan": ("scan", "scan_index", "scan_id")}


def _index_column(values: np.ndarray, limit: float, name: str, what: str) -> np.ndarray:
    ok = (values >= 0) & (values < limit) & (values == np.floor(values))
    if not np.all(ok):
        k = int(np.flatnonzero(~ok)[0])
        raise ValueError(f"{name}: vertex {k}: '{what}' value {values[k]:g}: not an integer in "
                         f"[0, {limit:g})")
    return values.astype(np.uint64)


def _text_values(values: np.ndarray, dtype, tokens: Optional[Sequence[bytes]] = None):
    """Numbers read from text (float64, or for 64-bit integers their tokens) as dtype: (array,
    None), or (None, the first value that dtype cannot hold) for an integer type."""
    dtype = np.dtype(dtype)
    if dtype.kind == "f":
        return values.astype(dtype), None
    if tokens is not None and dtype.itemsize == 8:
        try:
            return np.array([int(t) for t in tokens], dtype=dtype), None
        except (ValueError, OverflowError):
            pass
    info = np.iinfo(dtype)
    ok = (values == np.floor(values)) & (values >= info.min) & (values <= info.max)
    if np.all(ok):
        return values.astype(dtype), None
    k = int(np.flatnonzero(~ok)[0])
    return None, (k, tokens[k].decode("ascii", "replace") if tokens is not None else
                  f"{values[k]:g}")


def _ply_header(data: bytes, name: str):
    """(format, elements, num_cols, body offset); each element a dict of name, count and props
    (name, item type, list count type or None)."""
    lines_end = data.find(b"end_header")
    if not data.startswith(b"ply") or lines_end < 0:
        raise ValueError(f"{name}: not a PLY file (no 'ply' first line or no end_header)")
    newline = data.find(b"\n", lines_end)
    body_offset = len(data) if newline < 0 else newline + 1
    fmt = None
    elements: list[dict] = []
    num_cols = None
    for number, raw in enumerate(data[:lines_end].split(b"\n")[1:], start=2):
        f = [w.decode("ascii", "replace") for w in raw.split()]
        if not f or f[0] == "comment":
            continue
        if f[0] == "format":
            if len(f) != 3 or f[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise ValueError(f"{name}: line {number}: unsupported format {' '.join(f[1:])!r}")
            fmt = f[1]
        elif f[0] == "element":
            elements.append({"name": f[1], "count": int(f[2]), "props": []})
        elif f[0] == "property":
            if not elements:
                raise ValueError(f"{name}: line {number}: property before any element")
            if f[1] == "list":
                elements[-1]["props"].append((f[4], _PLY_TYPES[f[3]], _PLY_TYPES[f[2]]))
            elif f[1] in _PLY_TYPES:
                elements[-1]["props"].append((f[2], _PLY_TYPES[f[1]], None))
            else:
                raise ValueError(f"{name}: line {number}: unknown property type '{f[1]}'")
        elif f[0] == "obj_info":
            if len(f) == 3 and f[1] == "num_cols":
                num_cols = int(f[2])
        else:
            raise ValueError(f"{name}: line {number}: unknown header keyword '{f[0]}'")
    if fmt is None:
        raise ValueError(f"{name}: no 'format' line before end_header")
    return fmt, elements, num_cols, body_offset


def _ply_ascii_scalars(element: dict, entries: list[list[bytes]], name: str):
    """The scalar properties' tokens of an ascii element's entries (n × scalars), list
    properties skipped."""
    props = element["props"]
    if all(p[2] is None for p in props):
        width = len(props)
        bad = next((k for k, r in enumerate(entries) if len(r) != width), None)
        if bad is not None:
            raise ValueError(f"{name}: {element['name']} {bad}: {len(entries[bad])} values, the "
                             f"header declares {width}")
        return entries
    rows = []
    for k, entry in enumerate(entries):
        row, at = [], 0
        for prop in props:
            if at >= len(entry):
                raise ValueError(f"{name}: {element['name']} {k}: fewer values than the header "
                                 "declares")
            if prop[2] is None:
                row.append(entry[at])
                at += 1
            else:
                at += 1 + int(_number(entry[at]))
        if at != len(entry):
            raise ValueError(f"{name}: {element['name']} {k}: {len(entry)} values, the header "
                             f"declares {at}")
        rows.append(row)
    return rows


def _ply_ascii(body: bytes, elements: list[dict], vertex: dict, name: str, notes):
    """The vertex columns (float64), the attributes' typed columns and range_grid's cells of an
    ascii body."""
    rows = [r for r in (line.split() for line in _lines(body)) if r]
    columns: dict[str, np.ndarray] = {}
    typed: dict[str, np.ndarray] = {}
    grid_rows = None
    at = 0
    for element in elements:
        entries = rows[at:at + element["count"]]
        if len(entries) < element["count"]:
            raise ValueError(f"{name}: data ends before {element['name']} {len(entries)} of "
                             f"{element['count']} (truncated file or wrong count)")
        at += element["count"]
        if element is vertex:
            scalars = [p for p in element["props"] if p[2] is None]
            tokens = _ply_ascii_scalars(element, entries, name)
            values = _numbers([t for r in tokens for t in r], lambda: f"{name}: vertex").reshape(
                -1, len(scalars)) if entries else np.zeros((0, len(scalars)))
            for k, (prop, item, _) in enumerate(scalars):
                columns[prop] = values[:, k]
                typed[prop], bad = _text_values(values[:, k], item)
                if bad is not None:
                    del typed[prop]
                    if notes is not None:
                        notes.append(f"{name}: vertex property '{prop}' left out of "
                                     f"Scan.attributes: vertex {bad[0]} holds {bad[1]}, which "
                                     f"its type {np.dtype(item)} cannot")
        elif element["name"] == "range_grid":
            grid_rows = [(entry, int(r[1])) for entry, r in enumerate(entries)
                         if len(r) > 1 and r[0] != b"0"]
    if any(rows[at:]):
        raise ValueError(f"{name}: data after the last declared element (counts disagree)")
    return columns, typed, grid_rows


def _ply_binary_entries(body: bytes, pos: int, element: dict, order: str, cells: list):
    """An element with list properties, entry by entry: its scalar properties' values and the
    offset after it; range_grid's vertex_indices go to cells as (entry, vertex)."""
    scalars = {p[0]: [] for p in element["props"] if p[2] is None}
    grid = element["name"] == "range_grid"
    try:
        for entry in range(element["count"]):
            for prop, item, count_type in element["props"]:
                if count_type is None:
                    scalars[prop].append(struct.unpack_from(order + _STRUCT[item], body, pos)[0])
                    pos += int(item[1])
                    continue
                (items,) = struct.unpack_from(order + _STRUCT[count_type], body, pos)
                pos += int(count_type[1])
                values = struct.unpack_from(f"{order}{items}{_STRUCT[item]}", body, pos)
                pos += items * int(item[1])
                if grid and prop == "vertex_indices":
                    cells.extend((entry, int(v)) for v in values)
    except struct.error:
        raise ValueError(f"byte {pos}: data ends inside element '{element['name']}' (truncated "
                         "file)") from None
    return scalars, pos


def _ply_binary(body: bytes, body_offset: int, elements: list[dict], vertex: dict, order: str,
                name: str):
    """The vertex columns (float64), their typed columns and range_grid's cells of a binary
    body."""
    columns: dict[str, np.ndarray] = {}
    typed: dict[str, np.ndarray] = {}
    grid_rows = None
    pos = 0
    for element in elements:
        if all(p[2] is None for p in element["props"]):
            dtype = np.dtype([(p[0], order + p[1]) for p in element["props"]])
            size = dtype.itemsize * element["count"]
            if pos + size > len(body):
                raise ValueError(f"{name}: byte {body_offset + len(body)}: data ends inside "
                                 f"element '{element['name']}' (truncated file)")
            records = np.frombuffer(body, dtype=dtype, count=element["count"], offset=pos)
            pos += size
            if element is vertex:
                for p in element["props"]:
                    typed[p[0]] = records[p[0]].astype(np.dtype(p[1]))
            continue
        cells: list = []
        try:
            scalars, pos = _ply_binary_entries(body, pos, element, order, cells)
        except ValueError as e:
            raise ValueError(f"{name}: {e}") from None
        if element is vertex:
            for prop, item, _ in (p for p in element["props"] if p[2] is None):
                typed[prop] = np.array(scalars[prop], dtype=np.dtype(item))
        if element["name"] == "range_grid":
            grid_rows = cells
    if pos != len(body):
        raise ValueError(f"{name}: byte {body_offset + pos}: {len(body) - pos} bytes after "
                         "the last declared element (counts disagree)")
    for prop, values in typed.items():
        columns[prop] = values.astype(np.float64)
    return columns, typed, grid_rows


def _grid_scanlines(grid_rows, num_cols, n: int, name: str) -> np.ndarray:
    if num_cols is None:
        raise ValueError(f"{name}: range_grid element without 'obj_info num_cols'")
    scanline = np.zeros(n, dtype=np.uint32)
    seen = np.zeros(n, dtype=bool)
    for entry, v in grid_rows:
        if not 0 <= v < n or seen[v]:
            raise ValueError(f"{name}: range_grid {entry}: vertex index {v} is not a valid, "
                             "unlisted vertex")
        seen[v] = True
        scanline[v] = entry // num_cols
    if not seen.all():
        raise ValueError(f"{name}: range_grid lists {int(seen.sum())} of the {n} vertices; "
                         "every vertex needs a grid cell")
    return scanline


def _read_ply(data: bytes, name: str, notes):
    fmt, elements, num_cols, body_offset = _ply_header(data, name)
    vertex = next((e for e in elements if e["name"] == "vertex"), None)
    if vertex is None:
        raise ValueError(f"{name}: no 'vertex' element")
    scalar = {p[0]: p[1] for p in vertex["props"] if p[2] is None}
    for axis in "xyz":
        if axis not in scalar:
            raise ValueError(f"{name}: vertex element has no scalar property '{axis}'")
    n = vertex["count"]
    body = data[body_offset:]
    if fmt == "ascii":
        columns, typed, grid_rows = _ply_ascii(body, elements, vertex, name, notes)
    else:
        order = ">" if fmt == "binary_big_endian" else "<"
        columns, typed, grid_rows = _ply_binary(body, body_offset, elements, vertex, order, name)
    lists = [p[0] for p in vertex["props"] if p[2] is not None]
    if lists and notes is not None:
        notes.append(f"{name}: vertex list properties left out ({', '.join(lists)}): only one "
                     "value per point is kept")
    # The slot each alias feeds: the last present of each slot's names, as before attributes.
    used = {slot: [a for a in aliases if a in columns][-1:] for slot, aliases in
            _PLY_SLOTS.items()}
    scanline = None
    if used["scanline"]:
        scanline = _index_column(columns[used["scanline"][0]], 4294967296.0, name,
                                 used["scanline"][0]).astype(np.uint32)
    if grid_rows is not None:  # the grid's rows, not a scanline property
        scanline = _grid_scanlines(grid_rows, num_cols, n, name)
        used["scanline"] = []
    wide = any(scalar[a] == "f8" for a in "xyz")
    xyz = np.column_stack([columns[a] for a in "xyz"]) if n else np.zeros((0, 3))
    points = _coordinates(xyz, wide, name)
    per_point = {"scanline": scanline}
    if used["quality"]:
        q = columns[used["quality"][0]]
        per_point["quality"] = np.where(np.isnan(q), 0, np.clip(q, 0, 1)).astype(np.float32)
    if used["intensity"]:
        per_point["intensity"] = columns["intensity"].astype(np.float32)
    scan_column = None
    if used["scan"]:
        scan_column = _index_column(columns[used["scan"][0]], max(n, 1), name, used["scan"][0])
    taken = {"x", "y", "z", *(a for names in used.values() for a in names)}
    attributes = {k: v for k, v in typed.items() if k not in taken}
    finite = np.all(np.isfinite(points), axis=1)
    unmeasured = _Unmeasured(name, "vertex", finite)
    unmeasured.finish(int(finite.sum()), notes)
    stem = pathlib.Path(name).stem
    if scan_column is None or len(np.unique(scan_column)) <= 1:
        return [_scan(stem, points, per_point, finite, {}, attributes=attributes)]
    values, first = np.unique(scan_column, return_index=True)
    values = values[np.argsort(first)]  # in order of first appearance, as the CLI
    ids = [f"{stem}#{v}" for v in values]
    if notes is not None:
        notes.append(f"{name}: its scan column holds {len(ids)} scans, sent as {ids[0]} … "
                     f"{ids[-1]}")
    return [_scan(i, points, per_point, finite & (scan_column == v), {}, scan_column == v,
                  attributes) for i, v in zip(ids, values)]


def _scan(scan_id: str, points, per_point, keep, meta, member=None, attributes=None) -> Scan:
    """The points of `keep` with their per-point arrays and attributes; points_unmeasured counts
    those of `member` (all by default) that are not kept."""
    member = np.ones(len(points), dtype=bool) if member is None else member
    arrays = {k: (v[keep] if v is not None else None) for k, v in per_point.items()}
    kept = {k: np.ascontiguousarray(v[keep]) for k, v in (attributes or {}).items()}
    return Scan(points=np.ascontiguousarray(points[keep]), scan_id=scan_id,
                points_unmeasured=int(np.count_nonzero(member & ~keep)), attributes=kept,
                **arrays, **meta)


# ---------------------------------------------------------------------------------------- PCD

_PCD_SLOTS = ("x", "y", "z", "normal_x", "normal_y", "normal_z", "intensity", "flags", "scanline")
_PCD_DEFAULT_VIEWPOINT = [0, 0, 0, 1, 0, 0, 0]
_LZF = None


def _lzf_decompress(data: bytes, size: int, name: str) -> bytes:
    global _LZF
    if _LZF is None:
        path = ctypes.util.find_library("lzf")
        if path is None:
            raise ValueError(f"{name}: PCD DATA binary_compressed needs liblzf (Debian's "
                             "liblzf1), which is not installed; the CLI reads it, or save it "
                             "as DATA binary")
        _LZF = ctypes.CDLL(path)
        _LZF.lzf_decompress.restype = ctypes.c_uint
        _LZF.lzf_decompress.argtypes = [ctypes.c_char_p, ctypes.c_uint, ctypes.c_void_p,
                                        ctypes.c_uint]
    out = ctypes.create_string_buffer(max(size, 1))
    got = _LZF.lzf_decompress(data, len(data), out, size) if size else 0
    if got != size:
        raise ValueError(f"{name}: binary_compressed body: LZF data decompress to {got} bytes, "
                         f"not the {size} declared (corrupt data)")
    return out.raw[:size]


def _pcd_header(data: bytes, name: str) -> tuple[dict[str, list[str]], int]:
    """The header's lines by keyword (COLUMNS as FIELDS) and the body's offset."""
    header: dict[str, list[str]] = {}
    pos = 0
    while True:
        end = data.find(b"\n", pos)
        if end < 0 and pos >= len(data):
            raise ValueError(f"{name}: the header has no DATA line (not a PCD file, or truncated)")
        line = data[pos:len(data) if end < 0 else end]
        pos = len(data) if end < 0 else end + 1
        words = line.decode("ascii", "replace").split()
        if not words or words[0].startswith("#"):
            continue
        key = words[0].upper()
        header["FIELDS" if key == "COLUMNS" else key] = words[1:]
        if key == "DATA":
            return header, pos


def _pcd_ascii_attribute(table, rows, column: int, field: str, dtype: np.dtype, name: str,
                         notes) -> Optional[np.ndarray]:
    """An attribute column of an ascii body in its declared type; None, with a note, when a
    value does not fit it. PCL writes an F4 "rgb" as the uint32 of its bits: such integers are
    read back as those bits."""
    tokens = [r[column] for r in rows]
    if field == "rgb" and dtype == np.float32 and all(t.isdigit() for t in tokens):
        bits, bad = _text_values(table[:, column], np.uint32, tokens)
        if bad is None:
            return bits.view(np.float32)
    values, bad = _text_values(table[:, column], dtype, tokens)
    if bad is not None and notes is not None:
        notes.append(f"{name}: field '{field}' left out of Scan.attributes: point {bad[0]} "
                     f"holds {bad[1]}, which its type {dtype} cannot")
    return values


def _pcd_body(kind: str, body: bytes, header, fields, sizes, counts, dtypes, layout, keep, points,
              name, notes):
    """The layout's columns (float64) and the kept fields' columns in their declared types."""
    cols: dict[str, np.ndarray] = {}
    typed: dict[str, np.ndarray] = {}
    if kind == "ascii":
        rows = [r for r in (line.split() for line in _lines(body)) if r]
        values_per_point = sum(counts)
        if len(rows) != points:
            raise ValueError(f"{name}: {len(rows)} points in the ascii body, POINTS {points}")
        bad = next((k for k, r in enumerate(rows) if len(r) != values_per_point), None)
        if bad is not None:
            raise ValueError(f"{name}: point {bad} has {len(rows[bad])} values but the fields "
                             f"declare {values_per_point}")
        table = _numbers([t for r in rows for t in r], lambda: f"{name}: a field").reshape(
            points, values_per_point) if points else np.zeros((0, values_per_point))
        offsets = np.cumsum([0] + counts)
        for f, k in layout.items():
            cols[f] = table[:, offsets[k]]
        for k in keep:
            values = _pcd_ascii_attribute(table, rows, offsets[k], fields[k],
                                          np.dtype(dtypes[k][1]).newbyteorder("="), name, notes)
            if values is not None:
                typed[fields[k]] = values
    elif kind == "binary":
        dtype = np.dtype(dtypes)
        if dtype.itemsize * points != len(body):
            raise ValueError(f"{name}: POINTS {points} of {dtype.itemsize} bytes each need "
                             f"{dtype.itemsize * points} bytes, the binary body has {len(body)} "
                             "(truncated file or wrong count)")
        records = np.frombuffer(body, dtype=dtype, count=points)
        for f, k in layout.items():
            cols[f] = records[f].astype(np.float64)
        for k in keep:
            typed[fields[k]] = records[fields[k]].astype(records.dtype[fields[k]].newbyteorder("="))
    elif kind == "binary_compressed":
        if len(body) < 8:
            raise ValueError(f"{name}: binary_compressed body has {len(body)} bytes, fewer than "
                             "its 8-byte size prefix")
        compressed, uncompressed = (int(v) for v in np.frombuffer(body, "<u4", 2))
        record = sum(s * c for f, s, c in zip(fields, sizes, counts) if f != "_")
        if compressed > len(body) - 8 or record * points != uncompressed:
            raise ValueError(f"{name}: binary_compressed body declares {compressed} compressed "
                             f"and {uncompressed} uncompressed bytes for POINTS {points} of "
                             f"{record} bytes")
        raw = _lzf_decompress(body[8:8 + compressed], uncompressed, name)
        start = 0
        for k, ((f, t, shape), s, c) in enumerate(zip(dtypes, sizes, counts)):
            if f == "_":
                continue
            column = np.frombuffer(raw, dtype=t, count=points, offset=start) if c == 1 else None
            if f in layout and layout[f] == k:
                cols[f] = column.astype(np.float64)
            if k in keep:
                typed[f] = column.astype(column.dtype.newbyteorder("="))
            start += s * c * points
    else:
        raise ValueError(f"{name}: DATA '{' '.join(header['DATA'])}' is not ascii, binary or "
                         "binary_compressed")
    return cols, typed


def _read_pcd(data: bytes, name: str, notes):
    header, pos = _pcd_header(data, name)
    fields = header["FIELDS"]
    sizes = [int(s) for s in header["SIZE"]]
    types = header["TYPE"]
    counts = [int(c) for c in header.get("COUNT", ["1"] * len(fields))]
    width, height = int(header["WIDTH"][0]), int(header.get("HEIGHT", ["1"])[0])
    points = int(header.get("POINTS", [width * height])[0])
    if points != width * height:
        raise ValueError(f"{name}: POINTS {points} but WIDTH x HEIGHT = {width} x {height}")
    kind = header["DATA"][0].lower() if header["DATA"] else ""
    dtypes = []
    for f, s, t, c in zip(fields, sizes, types, counts):
        base = {"F": "f", "I": "i", "U": "u"}[t] + str(s)
        dtypes.append((f, "<" + base, (c,) if c != 1 else ()))
    layout: dict[str, int] = {}
    for k, f in enumerate(fields):
        readable = f in _PCD_SLOTS and not (
            (f == "flags" and (types[k], sizes[k]) != ("U", 1)) or
            (f == "scanline" and (types[k], sizes[k]) != ("U", 4)))
        if not readable:
            continue
        if counts[k] != 1:
            raise ValueError(f"{name}: field '{f}' has COUNT {counts[k]} (expected 1)")
        layout[f] = k
    for axis in "xyz":
        if axis not in layout:
            raise ValueError(f"{name}: no field '{axis}'")
    # Every other field of one value is kept as an attribute: the reader uses x y z, intensity
    # and (unorganised) scanline; the service computes its own normals and flags.
    used = {"x", "y", "z", "intensity"} | ({"scanline"} if height == 1 else set())
    keep = [k for k, f in enumerate(fields) if f != "_" and counts[k] == 1 and
            not (f in used and layout.get(f) == k)]
    left_out = [f"{f} (COUNT {c})" for f, c in zip(fields, counts) if f != "_" and c != 1]
    twice = [k for k in keep if fields.count(fields[k]) > 1]
    left_out += [f"{fields[k]} (appears twice)" for k in dict.fromkeys(twice)]
    keep = [k for k in keep if k not in twice]
    cols, typed = _pcd_body(kind, data[pos:], header, fields, sizes, counts, dtypes, layout, keep,
                            points, name, notes)
    wide = any(types[layout[a]] == "F" and sizes[layout[a]] == 8 for a in "xyz")
    xyz = np.column_stack([cols[a] for a in "xyz"]) if points else np.zeros((0, 3))
    pts = _coordinates(xyz, wide, name)
    finite = np.all(np.isfinite(pts), axis=1)
    _Unmeasured(name, "point", finite).finish(int(finite.sum()), notes)
    per_point = {"scanline": None, "intensity": None}
    if height > 1:
        per_point["scanline"] = (np.arange(points) // width).astype(np.uint32)
    elif "scanline" in cols:
        per_point["scanline"] = cols["scanline"].astype(np.uint32)
    if "intensity" in cols:
        per_point["intensity"] = cols["intensity"].astype(np.float32)
    if left_out and notes is not None:
        notes.append(f"{name}: fields left out: {', '.join(dict.fromkeys(left_out))}: "
                     "Scan.attributes keeps each other field of one value per point")
    meta = {}
    viewpoint = [float(v) for v in header["VIEWPOINT"]] if "VIEWPOINT" in header else None
    if viewpoint is None or viewpoint == _PCD_DEFAULT_VIEWPOINT:
        if notes is not None:
            notes.append(f"{name}: " + ("VIEWPOINT is PCL's default 0 0 0 1 0 0 0" if viewpoint
                                        else "no VIEWPOINT line") +
                         ": sensor origin unknown (give camera_position)")
    else:
        meta["camera_position"] = tuple(viewpoint[:3])
    return [_scan(pathlib.Path(name).stem, pts, per_point, finite, meta, attributes=typed)]


# --------------------------------------------------------------------------------------- text

def _read_xyz(data: bytes, name: str, notes):
    columns = {"x": 0, "y": 1, "z": 2}
    count = 3
    named = False
    declared = None
    first_data = True
    coords, line_numbers, scanline = [], [], []
    extra: dict[str, int] = {}  # the other named columns, kept as attributes
    for number, line in enumerate(_lines(data), start=1):
        if first_data:
            match = re.match(rb"[ \t]*#[ \t]*columns:(.*)", line)
            if match:
                names = [w.decode() for w in _split(match.group(1), commas=True)]
                columns = {n: k for k, n in enumerate(names) if n in ("x", "y", "z", "scanline")}
                extra = {n: k for k, n in enumerate(names) if n not in columns and n != "_"}
                count, named = len(names), True
                if not all(a in columns for a in "xyz"):
                    raise ValueError(f"{name}: line {number}: '# columns:' must name x, y and z")
        fields = _split(line.split(b"#", 1)[0], commas=True)
        if not fields:
            continue
        if first_data:
            first_data = False
            if len(fields) == 1 and fields[0].isdigit():
                declared = int(fields[0])
                continue
        if len(fields) < count:
            raise ValueError(f"{name}: line {number}: expected "
                             f"{f'{count} values (# columns:)' if named else 'x y z'}, found "
                             f"{len(fields)} value(s)")
        try:
            coords.append([_number(fields[columns[a]]) for a in "xyz"])
            if "scanline" in columns:
                scanline.append(_number(fields[columns["scanline"]]))
        except ValueError as e:
            raise ValueError(f"{name}: line {number}: '{e}' is not a number") from None
        line_numbers.append(number)
    xyz = np.array(coords, dtype=np.float64).reshape(-1, 3)
    finite = np.all(np.isfinite(xyz), axis=1)
    narrow_lost = np.flatnonzero(finite & ~np.all(np.isfinite(xyz.astype(np.float32)), axis=1))
    if len(narrow_lost):
        raise ValueError(f"{name}: line {line_numbers[narrow_lost[0]]}: not a finite float")
    if declared is not None and declared != len(xyz):
        raise ValueError(f"{name}: first line declares {declared} points but the file has "
                         f"{len(xyz)}")
    _Unmeasured(name, "line", finite, line_numbers).finish(int(finite.sum()), notes)
    per_point = {"scanline": None}
    if "scanline" in columns:
        lines = _index_column(np.array(scanline), 4294967296.0, name, "scanline")
        per_point["scanline"] = lines.astype(np.uint32)
    attributes = _text_attributes(data, extra, line_numbers, name, notes) if extra else {}
    return [_scan(pathlib.Path(name).stem, xyz, per_point, finite, {}, attributes=attributes)]


def _text_attributes(data: bytes, extra: Mapping[str, int], line_numbers: Sequence[int],
                     name: str, notes) -> dict[str, np.ndarray]:
    """The named columns other than x y z scanline, float64 (text declares no type), from the
    point lines; a column with a value that is not a number is left out with a note."""
    lines = _lines(data)
    rows = [_split(lines[number - 1].split(b"#", 1)[0], commas=True) for number in line_numbers]
    attributes = {}
    for column, k in extra.items():
        try:
            attributes[column] = _numbers([r[k] for r in rows], lambda: "")
        except ValueError as e:
            if notes is not None:
                notes.append(f"{name}: column '{column}' left out of Scan.attributes{e}")
    return attributes


# ------------------------------------------------------------------------------------- public

def read_conf(path: PathLike) -> dict[str, Pose]:
    """A scanalyze .conf (`bmesh FILE tx ty tz qx qy qz qw` per scan; `camera` lines and `#`
    comments skipped) as {FILE: to_common}, exactly as `scanprep process --conf`: the file stores
    Rᵀ (X_common = R(q)ᵀ·X + t), so to_common's rotation is q normalised and conjugated. Pass it
    to read_scans(conf=...) or set Scan.to_common from it; the first line for a file wins."""
    poses: dict[str, Pose] = {}
    for number, line in enumerate(pathlib.Path(path).read_text().splitlines(), start=1):
        fields = line.split()
        if not fields or fields[0].startswith("#") or fields[0] == "camera":
            continue
        if fields[0] not in ("bmesh", "mesh"):
            raise ValueError(f"{path}: line {number}: unknown keyword '{fields[0]}' (expected "
                             "bmesh or camera)")
        if len(fields) != 9:
            raise ValueError(f"{path}: line {number}: expected '{fields[0]} <file> tx ty tz qx qy "
                             f"qz qw', found {len(fields)} fields")
        try:
            v = [_number(f.encode()) for f in fields[2:]]
        except ValueError as e:
            raise ValueError(f"{path}: line {number}: '{e}' is not a number") from None
        if not all(math.isfinite(x) for x in v):
            raise ValueError(f"{path}: line {number}: a value is not a finite number")
        norm = math.hypot(*v[3:])
        if not norm > 1e-6:
            raise ValueError(f"{path}: line {number}: quaternion has (near) zero length")
        qx, qy, qz, qw = (x / norm for x in v[3:])
        poses.setdefault(fields[1], ((-qx, -qy, -qz, qw), (v[0], v[1], v[2])))
    return poses


def read_scans(path: PathLike, *, conf: Union[None, PathLike, Mapping[str, Pose]] = None,
               notes: Optional[list] = None) -> list[Scan]:
    """The scans of one file, as `scanprep process FILE` sends them: one, named by the file's
    stem, or one per value of a PLY scan column (STEM#VALUE, in order of first appearance).
    conf: a .conf path or read_conf's dict; every scan of the file gets the file's pose (a file
    it has no pose for is an error, as with --conf). notes: a list that gets the readers' notes
    (unmeasured points left out, fields left out of Scan.attributes, no VIEWPOINT, ...).
    Malformed files raise ValueError naming the file."""
    path = pathlib.Path(path)
    extension = path.suffix.lower()
    data = path.read_bytes()
    readers = {".ply": _read_ply, ".pcd": _read_pcd, **{e: _read_xyz for e in _TEXT_EXTENSIONS}}
    if extension in readers:
        try:
            scans = readers[extension](data, str(path), notes)
        except (KeyError, IndexError, ValueError, TypeError) as e:
            if isinstance(e, ValueError) and str(e).startswith(str(path)):
                raise
            raise ValueError(f"{path}: malformed {extension[1:].upper()} file ({type(e).__name__}: "
                             f"{e})") from e
    else:
        raise ValueError(f"{path}: unsupported file extension '{path.suffix}' (the Python reader "
                         f"reads {_READABLE}; the CLI also reads .e57 and .las)")
    if conf is not None:
        poses = conf if isinstance(conf, Mapping) else read_conf(conf)
        if path.name not in poses:
            raise ValueError(f"{conf if not isinstance(conf, Mapping) else 'conf'} has no pose "
                             f"for {path.name}")
        for scan in scans:
            scan.to_common = poses[path.name]
    return scans


def read_scan(path: PathLike, **options) -> Scan:
    """The one scan of a file (read_scans; ValueError when its scan column holds several)."""
    scans = read_scans(path, **options)
    if len(scans) != 1:
        raise ValueError(f"{path}: holds {len(scans)} scans ({scans[0].scan_id} …): use "
                         "read_scans")
    return scans[0]
