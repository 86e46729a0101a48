# SPDX-License-Identifier: Apache-2.0
"""Nothing a file carries is dropped (issue 40 item 7): the readers keep every per-point field they
do not otherwise use in Scan.attributes, in the file's type, for the points they keep; process()
asks for each returned point's position in the upload (JobHeader.return_source_index) and gives
the attributes back for exactly the points that survive (Result.source_index, .attributes); the
scanner's own per-point arrays that the service carries (scanline, quality, intensity) come back
as Result.scanline, .quality and .intensity, each surviving point's uploaded value.

The readers' and the result decoder's tests need no server; the end-to-end ones run against a
real scanprep-server ($SCANPREP_SERVER, tests/CMakeLists.txt) with a plane whose colour encodes
each point's upload position. Run by ctest with the installed package's venv."""

import ctypes.util
import pathlib
import tempfile
import unittest
import warnings
import zlib
from concurrent import futures

import grpc
import numpy as np

from scanprep.v1 import scanprep_pb2 as pb
from scanprep.v1 import scanprep_pb2_grpc as pb_grpc
from scanprep_client import Client, Scan, ScanprepError, check_scans, read_scan, read_scans
from scanprep_client.client import _result

from local_server import LocalServer

NAN_ROW = 3  # the vertex or point of the files below without a position


def cloud(n=12):
    """n points on a line with one NaN row, a colour per point and a float scalar."""
    xyz = np.column_stack([np.arange(n) * 0.5, np.zeros(n), np.full(n, 2.0)])
    xyz[NAN_ROW] = np.nan
    k = np.arange(n)
    colour = np.column_stack([k * 20 % 256, 255 - k, k * 7 % 256]).astype(np.uint8)
    return xyz, colour, (k * 0.25 - 1).astype(np.float32)


def write_ply(path, encoding, with_list=False):
    """A vertex element of x y z (float), red green blue (uchar), confidence_2 (float) [and a
    list property], then a face element."""
    xyz, colour, extra = cloud()
    listed = "property list uchar float weights\n" if with_list else ""
    header = (f"ply\nformat {encoding} 1.0\nelement vertex {len(xyz)}\n"
              "property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
              "property uchar green\nproperty uchar blue\nproperty float confidence_2\n"
              f"{listed}element face 1\nproperty list uchar int vertex_indices\n"
              "end_header\n").encode()
    if encoding == "ascii":
        rows = [f"{x!r} {y!r} {z!r} {r} {g} {b} {c!r}" + (f" 2 0.5 {k}" if with_list else "")
                for k, ((x, y, z), (r, g, b), c) in enumerate(zip(xyz, colour, extra))]
        body = ("\n".join(rows) + "\n3 0 1 2\n").encode()
    else:
        o = ">" if encoding == "binary_big_endian" else "<"
        fields = [("x", o + "f4"), ("y", o + "f4"), ("z", o + "f4"), ("red", "u1"),
                  ("green", "u1"), ("blue", "u1"), ("c", o + "f4")]
        if with_list:
            fields += [("count", "u1"), ("weights", o + "f4", (2,))]
        records = np.zeros(len(xyz), fields)
        records["x"], records["y"], records["z"] = xyz.T
        records["red"], records["green"], records["blue"] = colour.T
        records["c"] = extra
        if with_list:
            records["count"], records["weights"] = 2, [0.5, 1.5]
        body = records.tobytes() + b"\x03" + np.array([0, 1, 2], o + "i4").tobytes()
    path.write_bytes(header + body)


def packed_rgb(colour):
    """PCL's rgb: 0x00RRGGBB in a uint32 whose bits a float32 field holds."""
    c = colour.astype(np.uint32)
    return (c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]


def write_pcd(path, encoding):
    """FIELDS x y z rgb (F4, PCL's packed colour) label (U4) hist (F4, COUNT 3)."""
    xyz, colour, _ = cloud()
    rgb, n = packed_rgb(colour), len(xyz)
    header = (f"VERSION 0.7\nFIELDS x y z rgb label hist\nSIZE 4 4 4 4 4 4\nTYPE F F F F U F\n"
              f"COUNT 1 1 1 1 1 3\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 5 1 0 0 0\nPOINTS {n}\n"
              f"DATA {encoding}\n").encode()
    if encoding == "ascii":  # as PCL writes it: rgb as the uint32 of its bits
        body = "".join(f"{x!r} {y!r} {z!r} {c} {k + 100} 1 2 3\n"
                       for k, ((x, y, z), c) in enumerate(zip(xyz.astype(np.float32), rgb)))
        body = body.encode()
    else:
        records = np.zeros(n, [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4"),
                               ("label", "<u4"), ("hist", "<f4", (3,))])
        records["x"], records["y"], records["z"] = xyz.T
        records["rgb"], records["label"] = rgb, np.arange(n) + 100
        body = records.tobytes()
        if encoding == "binary_compressed":  # field by field, as LZF literal runs of 32 bytes
            raw = b"".join(np.ascontiguousarray(records[f]).tobytes() for f in records.dtype.names)
            lzf = b"".join(bytes([len(raw[i:i + 32]) - 1]) + raw[i:i + 32]
                           for i in range(0, len(raw), 32))
            body = np.array([len(lzf), len(raw)], "<u4").tobytes() + lzf
    path.write_bytes(header + body)


class ReaderAttributesTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = pathlib.Path(cls.enterClassContext(tempfile.TemporaryDirectory()))

    def test_ply_colour_and_scalar_in_every_encoding(self):
        xyz, colour, extra = cloud()
        kept = np.arange(len(xyz)) != NAN_ROW
        for encoding in ("ascii", "binary_little_endian", "binary_big_endian"):
            with self.subTest(encoding=encoding):
                path = self.tmp / f"colour_{encoding}.ply"
                write_ply(path, encoding)
                scan = read_scan(path)
                self.assertEqual(list(scan.attributes), ["red", "green", "blue", "confidence_2"])
                self.assertEqual(len(scan.points), len(xyz) - 1)  # the NaN row left out
                for k, channel in enumerate(("red", "green", "blue")):
                    self.assertEqual(scan.attributes[channel].dtype, np.uint8)
                    np.testing.assert_array_equal(scan.attributes[channel], colour[kept, k])
                self.assertEqual(scan.attributes["confidence_2"].dtype, np.float32)
                self.assertTrue(scan.attributes["confidence_2"].dtype.isnative)
                np.testing.assert_array_equal(scan.attributes["confidence_2"], extra[kept])
                self.assertIsNone(scan.quality)  # confidence_2 is not confidence

    def test_a_vertex_list_property_is_left_out_with_a_note(self):
        _, colour, _ = cloud()
        for encoding in ("ascii", "binary_little_endian"):
            with self.subTest(encoding=encoding):
                path = self.tmp / f"listed_{encoding}.ply"
                write_ply(path, encoding, with_list=True)
                notes = []
                scan = read_scan(path, notes=notes)
                self.assertEqual(list(scan.attributes), ["red", "green", "blue", "confidence_2"])
                np.testing.assert_array_equal(scan.attributes["blue"][:NAN_ROW],
                                              colour[:NAN_ROW, 2])
                self.assertTrue(any("vertex list properties left out (weights)" in n
                                    for n in notes), notes)

    def test_pcd_rgb_keeps_its_declared_type(self):
        xyz, colour, _ = cloud()
        kept = np.arange(len(xyz)) != NAN_ROW
        encodings = ["ascii", "binary"] + (["binary_compressed"] if ctypes.util.find_library(
            "lzf") else [])  # the reader needs liblzf for it
        for encoding in encodings:
            with self.subTest(encoding=encoding):
                path = self.tmp / f"colour_{encoding}.pcd"
                write_pcd(path, encoding)
                notes = []
                scan = read_scan(path, notes=notes)
                self.assertEqual(list(scan.attributes), ["rgb", "label"])
                rgb = scan.attributes["rgb"]
                self.assertEqual(rgb.dtype, np.float32)  # TYPE F, SIZE 4: the raw field
                np.testing.assert_array_equal(rgb.view(np.uint32), packed_rgb(colour)[kept])
                self.assertEqual(scan.attributes["label"].dtype, np.uint32)
                np.testing.assert_array_equal(scan.attributes["label"],
                                              np.flatnonzero(kept) + 100)
                self.assertTrue(any("fields left out: hist (COUNT 3)" in n for n in notes), notes)

    def test_a_scan_column_splits_the_attributes_too(self):
        path = self.tmp / "two.ply"
        path.write_text("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                        "property float y\nproperty float z\nproperty uchar scan\n"
                        "property short label\nend_header\n"
                        "0 0 0 3 -1\n1 0 0 1 -2\nnan 0 0 3 -3\n2 0 0 3 -4\n")
        scans = read_scans(path)
        self.assertEqual([s.attributes["label"].tolist() for s in scans], [[-1, -4], [-2]])
        self.assertEqual(scans[0].attributes["label"].dtype, np.int16)
        self.assertNotIn("scan", scans[0].attributes)  # the reader uses it

    def test_an_ascii_value_its_type_cannot_hold_is_left_out_with_a_note(self):
        path = self.tmp / "wide.ply"
        path.write_text("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                        "property float y\nproperty float z\nproperty uchar red\n"
                        "property uchar green\nend_header\n0 0 0 300 1\n1 0 0 4 2\n")
        notes = []
        scan = read_scan(path, notes=notes)
        self.assertEqual(list(scan.attributes), ["green"])
        self.assertTrue(any("'red' left out of Scan.attributes: vertex 0 holds 300" in n
                            for n in notes), notes)

    def test_text_keeps_the_columns_a_columns_line_names(self):
        path = self.tmp / "named.xyz"
        path.write_text("# columns: x y z red _ note\n0 0 0 10 9 a\nnan nan nan 11 9 b\n"
                        "1 0 0 12 9 c\n")
        notes = []
        scan = read_scan(path, notes=notes)
        self.assertEqual(list(scan.attributes), ["red"])
        self.assertEqual(scan.attributes["red"].dtype, np.float64)  # text declares no type
        np.testing.assert_array_equal(scan.attributes["red"], [10, 12])
        self.assertTrue(any("column 'note' left out" in n for n in notes), notes)
        plain = self.tmp / "plain.xyz"
        plain.write_text("0 0 0 10 11\n1 0 0 12 13\n")
        self.assertEqual(read_scan(plain).attributes, {})  # unnamed columns: none kept

    def test_check_scans_refuses_attributes_of_another_length(self):
        points = np.zeros((4, 3), dtype=np.float32)
        check_scans([Scan(points=points, attributes={"rgb": np.zeros((4, 3), np.uint8)})])
        for attributes, pattern in [({"red": np.zeros(3)}, r"attributes\['red'\]: shape \(3,\)"),
                                    ([np.zeros(4)], "expected a dict")]:
            with self.assertRaisesRegex(ValueError, "scan 0 .*" + pattern):
                check_scans([Scan(points=points, attributes=attributes)])


def result_stream(source_index, crc_with_index=True):
    """A hand-made result: one packed chunk of len(source_index) points, the report and the end
    message, whose CRC-32 covers source_index after flags (scanprep.proto) or not at all."""
    n = len(source_index)
    chunk = pb.PointChunk(xyz_packed=np.zeros(3 * n, "<f4").tobytes(),
                          scan_index_packed=np.zeros(n, "<u4").tobytes(), flags=bytes(n),
                          source_index_packed=np.asarray(source_index, "<u4").tobytes())
    crc = zlib.crc32(chunk.flags, zlib.crc32(chunk.scan_index_packed,
                                             zlib.crc32(chunk.xyz_packed)))
    if crc_with_index:
        crc = zlib.crc32(chunk.source_index_packed, crc)
    return [pb.ProcessResponse(points=chunk), pb.ProcessResponse(report=pb.Report()),
            pb.ProcessResponse(end=pb.StreamEnd(points=n, crc32=crc))]


class ResultDecodingTest(unittest.TestCase):
    def test_source_index_is_checksummed_after_flags(self):
        result = _result(iter(result_stream([0, 2, 5])), None, None, uploaded=6)
        self.assertEqual(result.source_index.dtype, np.uint32)
        self.assertEqual(result.source_index.tolist(), [0, 2, 5])
        with self.assertRaises(ScanprepError) as caught:
            _result(iter(result_stream([0, 2, 5], crc_with_index=False)), None, None, 6)
        self.assertEqual(caught.exception.code, grpc.StatusCode.DATA_LOSS)

    def test_source_index_beyond_the_upload_is_data_loss(self):
        with self.assertRaises(ScanprepError) as caught:
            _result(iter(result_stream([0, 6])), None, None, uploaded=6)
        self.assertEqual(caught.exception.code, grpc.StatusCode.DATA_LOSS)

    def test_not_asked_none_sent(self):
        self.assertIsNone(_result(iter(result_stream([])[1:]), None, None, 0).source_index)


def scanner_stream(n, **arrays):
    """A hand-made result of n points in one packed chunk carrying the given scanner arrays
    (scanline, quality, intensity: name=values), CRC-32 in the proto's field order."""
    chunk = pb.PointChunk(xyz_packed=np.arange(3 * n, dtype="<f4").tobytes(),
                          scan_index_packed=np.zeros(n, "<u4").tobytes(), flags=bytes(n))
    crc = zlib.crc32(chunk.scan_index_packed, zlib.crc32(chunk.xyz_packed))
    for name, dtype in (("scanline", "<u4"), ("quality", "<f4"), ("intensity", "<f4")):
        if name in arrays:
            setattr(chunk, f"{name}_packed", np.asarray(arrays[name], dtype).tobytes())
            crc = zlib.crc32(getattr(chunk, f"{name}_packed"), crc)
    crc = zlib.crc32(chunk.flags, crc)
    messages = [pb.ProcessResponse(points=chunk)] if n else []
    return messages + [pb.ProcessResponse(report=pb.Report()),
                       pb.ProcessResponse(end=pb.StreamEnd(points=n, crc32=crc))]


class ScannerArraysDecodingTest(unittest.TestCase):
    def test_each_array_in_its_wire_type(self):
        result = _result(iter(scanner_stream(3, scanline=[7, 8, 4294967295],
                                             quality=[0.5, 1, 0], intensity=[10.5, -2, 3e6])),
                         None, None, 0)
        self.assertEqual(result.scanline.dtype, np.uint32)
        self.assertEqual(result.quality.dtype, np.float32)
        self.assertEqual(result.intensity.dtype, np.float32)
        self.assertEqual(result.scanline.tolist(), [7, 8, 4294967295])
        self.assertEqual(result.quality.tolist(), [0.5, 1, 0])
        self.assertEqual(result.intensity.tolist(), [10.5, -2, 3e6])
        self.assertIsNone(result.normals)

    def test_absent_is_none_and_sent_with_no_point_back_is_empty(self):
        result = _result(iter(scanner_stream(2, intensity=[1, 2])), None, None, 0)
        self.assertIsNone(result.scanline)
        self.assertIsNone(result.quality)
        empty = _result(iter(scanner_stream(0)), None, None, 0, sent=["quality", "intensity"])
        self.assertEqual((empty.quality.dtype, empty.quality.shape), (np.float32, (0,)))
        self.assertEqual((empty.intensity.dtype, empty.intensity.shape), (np.float32, (0,)))
        self.assertIsNone(empty.scanline)

    def test_an_array_not_one_value_per_point_is_data_loss(self):
        for arrays in ({"intensity": [1, 2]}, {"scanline": [1, 2, 3, 4]}):
            with self.assertRaises(ScanprepError) as caught:
                _result(iter(scanner_stream(3, **arrays)), None, None, 0)
            self.assertEqual(caught.exception.code, grpc.StatusCode.DATA_LOSS)


class KeepEveryThird(pb_grpc.ScanPrepServicer):
    """A stand-in service that keeps every third uploaded point (by its position) and answers as
    the proto says, source_index in the CRC after the flags; it saw no source_index ask or no
    attribute on the wire."""

    def Process(self, requests, context):
        header, xyz = None, []
        for request in requests:
            if request.WhichOneof("kind") == "header":
                header = request.header
            elif request.WhichOneof("kind") == "points":
                xyz.append(np.frombuffer(request.points.xyz_packed, "<f4"))
        keep = np.arange(0, header.total_points, 3, dtype="<u4")
        chunk = pb.PointChunk(xyz_packed=np.concatenate(xyz).reshape(-1, 3)[keep].tobytes(),
                              scan_index_packed=np.zeros(len(keep), "<u4").tobytes(),
                              flags=bytes(len(keep)))
        crc = zlib.crc32(chunk.flags, zlib.crc32(chunk.scan_index_packed,
                                                 zlib.crc32(chunk.xyz_packed)))
        if header.return_source_index:
            chunk.source_index_packed = keep.tobytes()
            crc = zlib.crc32(chunk.source_index_packed, crc)
        yield pb.ProcessResponse(points=chunk)
        yield pb.ProcessResponse(report=pb.Report())
        yield pb.ProcessResponse(end=pb.StreamEnd(points=len(keep), crc32=crc))


class GatherTest(unittest.TestCase):
    """The client's side alone, against KeepEveryThird: the attributes of several scans gathered
    in upload order, NaN rows counted; a server that sends no source_index."""

    @classmethod
    def setUpClass(cls):
        server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
        pb_grpc.add_ScanPrepServicer_to_server(KeepEveryThird(), server)
        port = server.add_insecure_port("127.0.0.1:0")
        server.start()
        cls.addClassCleanup(server.stop, None)
        cls.target = f"127.0.0.1:{port}"
        cls.client = cls.enterClassContext(Client(cls.target, timeout=30))

    def test_attributes_follow_the_upload_order(self):
        sizes = [5, 7, 4]
        scans, start = [], 0
        for size in sizes:
            points = np.arange(3 * size, dtype=np.float32).reshape(-1, 3) + 3 * start
            points[1] = np.nan  # counted as a position, as the service counts it
            k = np.arange(start, start + size)
            scans.append(Scan(points=points, attributes={"k": k.astype(np.int64),
                                                         "pair": np.column_stack([k, -k])}))
            start += size
        result = self.client.process(scans, unit="mm")
        np.testing.assert_array_equal(result.source_index, np.arange(0, 16, 3))
        np.testing.assert_array_equal(result.attributes["k"], result.source_index)
        self.assertEqual(result.attributes["k"].dtype, np.int64)
        np.testing.assert_array_equal(result.attributes["pair"][:, 1], -result.attributes["k"])

    def test_a_server_that_sends_no_source_index(self):
        scan = Scan(points=np.zeros((4, 3), np.float32), attributes={"k": np.arange(4)})
        with Client(self.target, timeout=30) as client, self.assertWarnsRegex(
                UserWarning, "returned no source_index"):
            result = _without_index(client).process([scan], unit="mm")
        self.assertIsNone(result.source_index)
        self.assertEqual(result.attributes, {})


def _without_index(client):
    """client whose job headers lose return_source_index on the way, as an older server reads
    them."""
    process = client._stub.Process

    def older(requests, **kwargs):
        def stripped():
            for request in requests:
                if request.WhichOneof("kind") == "header":
                    request.header.return_source_index = False
                yield request
        return process(stripped(), **kwargs)
    client._stub.Process = older
    return client


def coloured_plane():
    """A 60 × 60 plane (0.5 mm apart, 0.01 mm noise) as two scans of 30 scanlines, with one spike
    10 mm above it and one NaN row; each point's colour is its upload position k: red = k % 256,
    green = k // 256 % 256, blue = k // 65536. Returns the scans, all points uploaded (n × 3) and
    the spike's and the NaN row's positions."""
    rng = np.random.default_rng(11)
    u, v = np.meshgrid(np.arange(60) * 0.5, np.arange(60) * 0.5)
    points = np.column_stack([u.ravel(), v.ravel(), rng.normal(0, 0.01, u.size)])
    spike, nan_row = 1234, 700
    points[spike, 2] += 10
    points[nan_row] = np.nan
    k = np.arange(len(points))
    colour = {"red": (k % 256).astype(np.uint8), "green": (k // 256 % 256).astype(np.uint8),
              "blue": (k // 65536).astype(np.uint8)}
    scans = []
    for i, rows in enumerate((slice(0, 1800), slice(1800, 3600))):
        scans.append(Scan(points=points[rows].astype(np.float32), scan_id=f"half{i}",
                          scanline=(k[rows] // 60).astype(np.uint32), scanline_spacing=0.5,
                          view_direction=(0, 0, 1), uncertainty=0.01,
                          attributes={c: values[rows] for c, values in colour.items()}))
    return scans, points.astype(np.float32), spike, nan_row


def decoded(attributes):
    return (attributes["red"].astype(np.int64) + 256 * attributes["green"].astype(np.int64) +
            65536 * attributes["blue"].astype(np.int64))


class EndToEndTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        server = cls.enterClassContext(LocalServer())
        cls.client = cls.enterClassContext(Client(server.target, timeout=120))
        cls.headers = []
        process = cls.client._stub.Process

        def capturing(requests, **kwargs):  # records each job's header on its way out
            def passed():
                for request in requests:
                    if request.WhichOneof("kind") == "header":
                        cls.headers.append(request.header)
                    yield request
            return process(passed(), **kwargs)
        cls.client._stub.Process = capturing

    def process(self, scans, **options):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # none expected unless a test says so
            return self.client.process(scans, unit="mm", **options)

    def assert_follows_its_colour(self, result, uploaded, tolerance=0.1):
        """Every returned point's colour is its source_index, and it lies within tolerance (mm;
        less than the plane's 0.5 mm spacing, so that a neighbour's index fails) of the point
        uploaded there (the smoothing moves a point by about the 0.01 mm noise)."""
        self.assertIsNotNone(result.source_index)
        self.assertEqual(result.source_index.dtype, np.uint32)
        self.assertEqual(len(result.source_index), len(result.points))
        self.assertTrue(np.all(np.diff(result.source_index.astype(np.int64)) > 0))
        self.assertEqual(len(result.attributes["red"]), len(result.points))
        np.testing.assert_array_equal(decoded(result.attributes), result.source_index)
        gap = np.linalg.norm(result.points - uploaded[result.source_index], axis=1)
        self.assertLess(gap.max(), tolerance)

    def test_colour_follows_every_returned_point(self):
        scans, uploaded, spike, nan_row = coloured_plane()
        result = self.process(scans)
        self.assertTrue(self.headers[-1].return_source_index)
        self.assert_follows_its_colour(result, uploaded)
        self.assertEqual(result.attributes["red"].dtype, np.uint8)
        self.assertNotIn(spike, set(decoded(result.attributes)))  # the spike did not survive
        self.assertNotIn(nan_row, set(result.source_index))
        # The default plan thins the plane (simplify): what is left still follows its colour.
        self.assertEqual(len(result.points), result.report.points_returned)
        self.assertGreater(len(result.points), 100)
        self.assertEqual(result.report.points_invalid, 1)

    def test_include_removed_returns_every_position_but_the_invalid(self):
        scans, uploaded, spike, nan_row = coloured_plane()
        result = self.process(scans, include_removed=True, stages=["outliers"])
        np.testing.assert_array_equal(result.source_index,
                                      np.delete(np.arange(len(uploaded)), nan_row))
        self.assert_follows_its_colour(result, uploaded, tolerance=1e-6)
        at_spike = np.flatnonzero(result.source_index == spike)
        self.assertTrue(result.flags[at_spike[0]] & 1)  # REMOVED_OUTLIER, and kept its colour

    def test_repeated_result_arrays_give_the_same(self):
        scans, uploaded, _, _ = coloured_plane()
        packed = self.process(scans, stages=["outliers"])
        repeated = self.process(scans, stages=["outliers"],
                                _result_arrays=pb.ARRAY_ENCODING_REPEATED)
        np.testing.assert_array_equal(repeated.source_index, packed.source_index)
        np.testing.assert_array_equal(repeated.points, packed.points)
        self.assert_follows_its_colour(repeated, uploaded, tolerance=1e-6)

    def test_from_a_file(self):
        # Through the reader: the NaN vertex is left out before the upload, so the colour (the
        # file's row) and source_index (the upload's position) differ past it.
        scans, uploaded, spike, nan_row = coloured_plane()
        rows = len(uploaded)
        with tempfile.TemporaryDirectory() as tmp:
            path = pathlib.Path(tmp) / "plane.ply"
            records = np.zeros(rows, [("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                      ("red", "u1"), ("green", "u1"), ("blue", "u1")])
            records["x"], records["y"], records["z"] = uploaded.T
            for channel in ("red", "green", "blue"):
                records[channel] = np.concatenate([s.attributes[channel] for s in scans])
            path.write_bytes((f"ply\nformat binary_little_endian 1.0\nelement vertex {rows}\n"
                              "property float x\nproperty float y\nproperty float z\n"
                              "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                              "end_header\n").encode() + records.tobytes())
            scan = read_scan(path)
        scan.scanline_spacing, scan.uncertainty, scan.view_direction = 0.5, 0.01, (0, 0, 1)
        result = self.process([scan])
        rows_back = decoded(result.attributes)
        np.testing.assert_array_equal(rows_back, result.source_index + (result.source_index >=
                                                                        nan_row))
        gap = np.linalg.norm(result.points - uploaded[rows_back], axis=1)
        self.assertLess(gap.max(), 0.1)
        self.assertNotIn(spike, set(rows_back))

    def test_control_no_attributes_no_source_index(self):
        scans, _, _, _ = coloured_plane()
        for scan in scans:
            scan.attributes = {}
        result = self.process(scans, stages=["outliers"])
        self.assertFalse(self.headers[-1].return_source_index)  # no extra bytes asked for
        self.assertIsNone(result.source_index)
        self.assertEqual(result.attributes, {})
        asked = self.process(scans, stages=["outliers"], return_source_index=True)
        self.assertTrue(self.headers[-1].return_source_index)
        self.assertEqual(len(asked.source_index), len(asked.points))
        self.assertEqual(asked.attributes, {})
        np.testing.assert_array_equal(asked.points, result.points)

    def test_an_attribute_not_in_every_scan_is_left_out_with_a_warning(self):
        scans, uploaded, _, _ = coloured_plane()
        scans[0].attributes["label"] = np.ones(len(scans[0].points), np.int32)
        scans[1].attributes["red"] = scans[1].attributes["red"].astype(np.float32)
        with self.assertWarns(UserWarning) as caught:
            result = self.client.process(scans, unit="mm", stages=["outliers"])
        message = str(caught.warning)
        self.assertIn("'label' (scan 1 ('half1') has none)", message)
        self.assertIn("'red' (uint8 in scan 0 ('half0'), float32 in scan 1 ('half1'))", message)
        self.assertEqual(list(result.attributes), ["green", "blue"])
        self.assertEqual(len(result.attributes["blue"]), len(result.points))

    def test_health_asks_for_no_source_index(self):
        scans, _, _, _ = coloured_plane()
        self.assertIsNotNone(self.client.health(scans, unit="mm"))
        self.assertFalse(self.headers[-1].return_source_index)


def scanner_plane():
    """coloured_plane's scans without their attributes, each point with its own scanline (its
    grid row), a random intensity and a random quality in [0.3, 1]. Returns the scans, all points
    uploaded, those three arrays over the upload (the ground truth), the spike's and the NaN
    row's positions."""
    scans, uploaded, spike, nan_row = coloured_plane()
    rng = np.random.default_rng(5)
    truth = {"scanline": np.concatenate([s.scanline for s in scans]).astype(np.uint32),
             "intensity": rng.uniform(0, 4095, len(uploaded)).astype(np.float32),
             "quality": rng.uniform(0.3, 1.0, len(uploaded)).astype(np.float32)}
    start = 0
    for scan in scans:
        rows = slice(start, start + len(scan.points))
        scan.attributes = {}
        scan.intensity, scan.quality = truth["intensity"][rows], truth["quality"][rows]
        start = rows.stop
    return scans, uploaded, truth, spike, nan_row


class ScannerArraysEndToEndTest(unittest.TestCase):
    """Through a real server: Result.scanline, .quality and .intensity are, for each returned
    point, the values uploaded at its source_index (ground truth from the input)."""

    @classmethod
    def setUpClass(cls):
        server = cls.enterClassContext(LocalServer())
        cls.client = cls.enterClassContext(Client(server.target, timeout=120))

    def process(self, scans, **options):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            return self.client.process(scans, unit="mm", return_source_index=True, **options)

    def assert_uploaded_values(self, result, truth):
        n = len(result.points)
        self.assertEqual(len(result.source_index), n)
        for name, dtype in (("scanline", np.uint32), ("quality", np.float32),
                            ("intensity", np.float32)):
            values = getattr(result, name)
            self.assertIsNotNone(values, name)
            self.assertEqual((values.dtype, values.shape), (np.dtype(dtype), (n,)), name)
            np.testing.assert_array_equal(values, truth[name][result.source_index], name)
        self.assertTrue(np.all((result.quality >= 0) & (result.quality <= 1)))  # scanprep.proto

    def test_default_plan_returns_each_surviving_points_own_values(self):
        scans, uploaded, truth, spike, nan_row = scanner_plane()
        result = self.process(scans)
        self.assert_uploaded_values(result, truth)
        # Not the whole upload in order: the spike was removed and the plane thinned.
        self.assertNotIn(spike, set(result.source_index))
        self.assertNotIn(nan_row, set(result.source_index))
        self.assertGreater(len(result.points), 100)
        self.assertLess(len(result.points), len(uploaded) - 2)

    def test_include_removed_gives_the_removed_points_their_values_too(self):
        scans, uploaded, truth, spike, nan_row = scanner_plane()
        result = self.process(scans, stages=["outliers"], include_removed=True)
        np.testing.assert_array_equal(result.source_index,
                                      np.delete(np.arange(len(uploaded)), nan_row))
        self.assert_uploaded_values(result, truth)
        at_spike = np.flatnonzero(result.source_index == spike)[0]
        self.assertTrue(result.flags[at_spike] & 1)  # REMOVED_OUTLIER, its intensity kept
        self.assertEqual(result.intensity[at_spike], truth["intensity"][spike])

    def test_repeated_result_arrays_give_the_same(self):
        scans, _, truth, _, _ = scanner_plane()
        packed = self.process(scans, stages=["outliers"])
        repeated = self.process(scans, stages=["outliers"],
                                _result_arrays=pb.ARRAY_ENCODING_REPEATED)
        self.assert_uploaded_values(repeated, truth)
        for name in ("scanline", "quality", "intensity"):
            np.testing.assert_array_equal(getattr(repeated, name), getattr(packed, name))

    def test_from_a_ply_file(self):
        # The reader's scanline, confidence (quality) and intensity properties, sent and back.
        scans, uploaded, truth, _, nan_row = scanner_plane()
        keep = np.delete(np.arange(len(uploaded)), nan_row)  # a file row needs a position
        records = np.zeros(len(keep), [("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                       ("scanline", "<u4"), ("confidence", "<f4"),
                                       ("intensity", "<f4")])
        records["x"], records["y"], records["z"] = uploaded[keep].T
        records["scanline"], records["confidence"] = truth["scanline"][keep], truth["quality"][keep]
        records["intensity"] = truth["intensity"][keep]
        with tempfile.TemporaryDirectory() as tmp:
            path = pathlib.Path(tmp) / "plane.ply"
            path.write_bytes((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(keep)}\n"
                              "property float x\nproperty float y\nproperty float z\n"
                              "property uint scanline\nproperty float confidence\n"
                              "property float intensity\nend_header\n").encode() +
                             records.tobytes())
            scan = read_scan(path)
        scan.scanline_spacing, scan.uncertainty, scan.view_direction = 0.5, 0.01, (0, 0, 1)
        result = self.process([scan])
        self.assert_uploaded_values(result, {name: truth[name][keep] for name in truth})

    def test_control_a_job_without_them_gets_none(self):
        scans, _, _, _, _ = scanner_plane()
        for scan in scans:
            scan.scanline = scan.quality = scan.intensity = None
        result = self.process(scans, stages=["outliers"])
        self.assertGreater(len(result.points), 0)
        self.assertIsNone(result.scanline)
        self.assertIsNone(result.quality)
        self.assertIsNone(result.intensity)


if __name__ == "__main__":
    unittest.main()
