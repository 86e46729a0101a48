# SPDX-License-Identifier: Apache-2.0
"""The Python readers (scanprep_client.read_scans, read_conf) against the CLI's C++ readers: each
file is sent by `scanprep process FILE --stages neighbourhoods --include_removed -o OUT.ply`
through a real scanprep-server, which returns every point in the order sent; the Python reader
must yield the same points, scanlines and unmeasured count. Then the bunny pair posed by bun.conf
through Python keeps as many points as `scanprep process --conf` (the pose as written, Rᵀ, gives
another count), and the typed report. Needs SCANPREP_SERVER and the CLI beside it
(build/client/scanprep, or SCANPREP_CLI); the shared scans (../shared/data) are skipped when
absent, the synthetic files are not."""

import json
import os
import pathlib
import re
import subprocess
import tempfile
import unittest

import numpy as np

from scanprep_client import Client, Report, Scan, read_conf, read_scan, read_scans

from local_server import LocalServer

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = pathlib.Path(os.environ.get("SCANPREP_DATA_DIR", ROOT.parent / "shared" / "data"))
BUNNY = DATA / "stanford_bunny_range_scans"


def cli_path() -> pathlib.Path:
    if "SCANPREP_CLI" in os.environ:
        return pathlib.Path(os.environ["SCANPREP_CLI"])
    return pathlib.Path(os.environ["SCANPREP_SERVER"]).resolve().parents[1] / "client" / "scanprep"


def synthetic_cloud(n=300, seed=3):
    """A wavy patch of n points in 10 scanlines, with NaN points at 5 and 17 and per-point
    quality and intensity."""
    rng = np.random.default_rng(seed)
    xyz = np.column_stack([rng.uniform(0, 20, n), rng.uniform(0, 20, n), rng.normal(0, 0.2, n)])
    xyz[[5, 17]] = np.nan
    return xyz, np.arange(n, dtype=np.uint32) // (n // 10), rng.uniform(0, 1.2, n), \
        rng.uniform(0, 500, n)


def write_ply(path, encoding, coord="float"):
    xyz, scanline, quality, intensity = synthetic_cloud()
    header = (f"ply\nformat {encoding} 1.0\ncomment synthetic\nelement vertex {len(xyz)}\n"
              f"property {coord} x\nproperty {coord} y\nproperty {coord} z\n"
              "property float confidence\nproperty uchar red\nproperty uint scanline\n"
              "property float intensity\nelement face 1\nproperty list uchar int vertex_indices\n"
              "end_header\n").encode()
    if encoding == "ascii":
        rows = "".join(f"{x!r} {y!r} {z!r} {q!r} 7 {s} {i!r}\n"
                       for (x, y, z), q, s, i in zip(xyz, quality, scanline, intensity))
        body = (rows + "3 0 1 2\n").encode()
    else:
        order = ">" if encoding == "binary_big_endian" else "<"
        c = "f8" if coord == "double" else "f4"
        dtype = np.dtype([("x", order + c), ("y", order + c), ("z", order + c),
                          ("q", order + "f4"), ("r", "u1"), ("s", order + "u4"),
                          ("i", order + "f4")])
        records = np.zeros(len(xyz), dtype)
        records["x"], records["y"], records["z"] = xyz.T
        records["q"], records["r"], records["s"], records["i"] = quality, 7, scanline, intensity
        face = np.array([3], "u1").tobytes() + np.array([0, 1, 2], order + "i4").tobytes()
        body = records.tobytes() + face
    path.write_bytes(header + body)


def write_pcd(path, encoding, height=1):
    xyz, *_ = synthetic_cloud()
    n = len(xyz)
    header = (f"# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\n"
              f"COUNT 1 1 1 1\nWIDTH {n // height}\nHEIGHT {height}\n"
              f"VIEWPOINT 1.5 -2 30 1 0 0 0\nPOINTS {n}\nDATA {encoding}\n").encode()
    if encoding == "ascii":
        body = "".join(f"{x!r} {y!r} {z!r} 4808\n" for x, y, z in xyz.astype(np.float32)).encode()
    else:
        records = np.zeros(n, [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
        records["x"], records["y"], records["z"] = xyz.T
        body = records.tobytes()
    path.write_bytes(header + body)


def write_xyz(path):
    xyz, *_ = synthetic_cloud()
    lines = [f"{len(xyz)}", "# a laser line"]
    lines += [f"{x!r}, {y!r}, {z!r}, 1 2 # row {k}" for k, (x, y, z) in enumerate(xyz)]
    path.write_text("\n".join(lines).replace("nan, nan, nan", "nan nan nan") + "\n")


def read_cli_output(path: pathlib.Path):
    """OUT.ply as the CLI writes it (binary little endian: x y z [nx ny nz] flags scan
    [scanline]), decoded here without the reader under test."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    props = re.findall(rb"property (\w+) (\w+)", data[:end])
    types = {b"float": "<f4", b"double": "<f8", b"uchar": "u1", b"uint": "<u4"}
    dtype = np.dtype([(name.decode(), types[t]) for t, name in props])
    records = np.frombuffer(data, dtype, offset=end)
    return records


class ReadersAgainstTheCliTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = cls.enterClassContext(LocalServer())
        cls.tmp = pathlib.Path(cls.enterClassContext(tempfile.TemporaryDirectory()))
        cls.cli = cli_path()

    def through_cli(self, path: pathlib.Path, *flags):
        out = self.tmp / f"{path.stem}.out.ply"
        run = subprocess.run([str(self.cli), "process", str(path), "--server", self.server.target,
                              "--stages", "neighbourhoods", "--include_removed", "--progress",
                              "off", "-o", str(out), *flags],
                             capture_output=True, text=True, timeout=120)
        self.assertEqual(run.returncode, 0, run.stderr)
        return read_cli_output(out), run.stderr

    def assert_same_as_cli(self, path: pathlib.Path, scanlines=True):
        records, stderr = self.through_cli(path)
        notes = []
        scan = read_scan(path, notes=notes)
        self.assertEqual(scan.scan_id, path.stem)
        self.assertEqual(len(scan.points), len(records), path)
        cli_xyz = np.column_stack([records[a] for a in "xyz"])
        if cli_xyz.dtype == np.float32:  # near zero: float coordinates, bit for bit
            np.testing.assert_array_equal(scan.points.astype(np.float32), cli_xyz,
                                          err_msg=str(path))
        else:  # far from zero: the CLI wrote origin + local in double
            np.testing.assert_allclose(scan.points, cli_xyz, rtol=1e-7, err_msg=str(path))
        if scanlines:
            self.assertIsNotNone(scan.scanline, path)
            np.testing.assert_array_equal(scan.scanline, records["scanline"], err_msg=str(path))
        unmeasured = re.search(r": (\d+) of \d+ points have no measurement", stderr)
        self.assertEqual(scan.points_unmeasured, int(unmeasured.group(1)) if unmeasured else 0)
        self.assertEqual(bool(unmeasured), any("no measurement" in n for n in notes))
        return scan, notes

    def test_synthetic_ply_in_every_encoding(self):
        for encoding, coord in [("ascii", "float"), ("binary_little_endian", "float"),
                                ("binary_big_endian", "float"), ("binary_big_endian", "double")]:
            with self.subTest(encoding=encoding, coord=coord):
                path = self.tmp / f"patch_{encoding}_{coord}.ply"
                write_ply(path, encoding, coord)
                scan, _ = self.assert_same_as_cli(path)
                self.assertEqual(scan.points_unmeasured, 2)
                self.assertEqual(scan.points.dtype, np.float64 if coord == "double"
                                 else np.float32)
                self.assertTrue(np.all((scan.quality >= 0) & (scan.quality <= 1)))
                self.assertEqual(len(scan.intensity), len(scan.points))
                self.assertEqual(list(scan.attributes), ["red"])  # the rest the reader uses
                np.testing.assert_array_equal(scan.attributes["red"], np.full(298, 7, np.uint8))

    def test_synthetic_pcd_and_text(self):
        for name, write in [("plain.pcd", lambda p: write_pcd(p, "ascii")),
                            ("binary.pcd", lambda p: write_pcd(p, "binary")),
                            ("organised.pcd", lambda p: write_pcd(p, "binary", height=10)),
                            ("laser.xyz", write_xyz)]:
            with self.subTest(file=name):
                path = self.tmp / name
                write(path)
                scan, notes = self.assert_same_as_cli(path, scanlines=name == "organised.pcd")
                self.assertEqual(scan.points_unmeasured, 2)
                if name.endswith(".pcd"):
                    self.assertEqual(scan.camera_position, (1.5, -2.0, 30.0))
                    self.assertEqual(scan.attributes["rgb"].dtype, np.uint32)  # TYPE U, SIZE 4
                    self.assertEqual(len(scan.attributes["rgb"]), len(scan.points))
                    self.assertFalse(any("left out:" in n for n in notes), notes)

    def test_shared_scans(self):
        files = [BUNNY / "bun000.ply",  # ascii, range_grid scanlines
                 DATA / "pcl_table_scene_mug_stereo" / "table_scene_mug_stereo_textured.pcd",
                 DATA / "cognex_laser_line_scan" / "triangulated.xyz"]
        if not all(f.is_file() for f in files):
            self.skipTest(f"shared scans not found under {DATA} (set SCANPREP_DATA_DIR)")
        scans = {}
        for path in files:
            with self.subTest(file=path.name):
                scans[path.suffix], _ = self.assert_same_as_cli(path,
                                                                scanlines=path.suffix != ".xyz")
        # binary_compressed, organised 640×480, NaN cells, a VIEWPOINT that is not PCL's default
        self.assertEqual(scans[".pcd"].camera_position, (0.0, 0.0, 0.0))
        self.assertEqual(scans[".pcd"].points_unmeasured, 97920)

    def test_a_scan_column_makes_one_scan_per_value(self):
        path = self.tmp / "two.ply"
        path.write_text("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                        "property float y\nproperty float z\nproperty uchar scan\nend_header\n"
                        "0 0 0 3\n1 0 0 1\n2 0 0 3\nnan 0 0 1\n")
        scans = read_scans(path)
        self.assertEqual([s.scan_id for s in scans], ["two#3", "two#1"])
        self.assertEqual([len(s.points) for s in scans], [2, 1])
        self.assertEqual([s.points_unmeasured for s in scans], [0, 1])
        with self.assertRaisesRegex(ValueError, "holds 2 scans"):
            read_scan(path)

    def test_malformed_files_name_the_file(self):
        cases = {"nothing.xyz": ("# only a comment\n", "no points in the file"),
                 "allnan.xyz": ("nan nan nan\n", "all 1 have no measurement"),
                 "short.ply": ("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                               "property float y\nproperty float z\nend_header\n0 0 0\n",
                               "data ends before vertex"),
                 "scan.e57": ("", "unsupported file extension"),
                 "count.pts": ("3\n0 0 0\n", "declares 3 points but the file has 1"),
                 "nosize.pcd": ("FIELDS x y z\nWIDTH 1\nDATA ascii\n0 0 0\n",
                                "malformed PCD file")}
        for name, (text, message) in cases.items():
            with self.subTest(file=name):
                path = self.tmp / name
                path.write_text(text)
                with self.assertRaisesRegex(ValueError, re.escape(name) + ".*" + message):
                    read_scans(path)


class ConfAndReportTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if not (BUNNY / "bun.conf").is_file():
            raise unittest.SkipTest(f"{BUNNY} not found (set SCANPREP_DATA_DIR)")
        cls.server = cls.enterClassContext(LocalServer())
        cls.tmp = pathlib.Path(cls.enterClassContext(tempfile.TemporaryDirectory()))

    def python_job(self, poses):
        job = json.loads((ROOT / "client" / "examples" / "bunny.job.json").read_text())
        meta = {s.pop("scan_id"): s for s in job["scans"]}
        scans = []
        for name in ("bun000", "bun045"):
            scan = read_scan(BUNNY / f"{name}.ply", conf=poses)
            scan.view_direction = tuple(meta[name]["view_direction"].get(a, 0) for a in "xyz")
            for field in ("scanline_spacing", "point_spacing", "uncertainty"):
                setattr(scan, field, meta[name][field])
            scans.append(scan)
        with Client(self.server.target) as client:
            return client.process(scans, unit="m", job_id=job["job_id"])

    def test_the_conf_helper_poses_the_bunny_as_the_cli_does(self):
        out = self.tmp / "bunny.ply"
        run = subprocess.run([str(cli_path()), "process", str(BUNNY / "bun000.ply"),
                              str(BUNNY / "bun045.ply"), "--conf", str(BUNNY / "bun.conf"),
                              "--job", str(ROOT / "client" / "examples" / "bunny.job.json"),
                              "--server", self.server.target, "--progress", "off", "-o", str(out)],
                             capture_output=True, text=True, timeout=120)
        self.assertEqual(run.returncode, 0, run.stderr)
        cli_kept = len(read_cli_output(out))
        poses = read_conf(BUNNY / "bun.conf")
        result = self.python_job(poses)
        self.assertEqual(len(result.points), cli_kept)
        # The pose as written (R, not the Rᵀ the file stores) merges another cloud.
        raw = {}
        for line in (BUNNY / "bun.conf").read_text().splitlines():
            f = line.split()
            if f[:1] == ["bmesh"]:
                raw[f[1]] = (tuple(map(float, f[5:9])), tuple(map(float, f[2:5])))
        self.assertNotEqual(len(self.python_job(raw).points), cli_kept)

        report = result.typed_report
        self.assertIsInstance(report, Report)
        self.assertEqual(report.job_id, "bunny-demo")
        self.assertEqual(report.points_received, sum(len(s.points) for s in
                                                    [read_scan(BUNNY / "bun000.ply"),
                                                     read_scan(BUNNY / "bun045.ply")]))
        self.assertEqual(report.points_returned, cli_kept)
        self.assertEqual([s.name for s in report.stages], [s.name for s in result.report.stages])
        self.assertEqual(report.stages[-1].points_out, cli_kept)
        self.assertEqual(report.stage("outliers").points_in, report.points_processed)
        self.assertGreater(report.stage("outliers").seconds, 0)
        self.assertIn("outliers.method", report.stage("outliers").text_parameters)
        self.assertEqual(len(report.warnings), len(result.report.warnings))
        self.assertTrue(all(w.code for w in report.warnings))
        self.assertEqual(report.budget.met, result.report.budget_met)
        self.assertIsNotNone(report.health)
        with self.assertRaisesRegex(KeyError, "did not run"):
            report.stage("no_such_stage")

    def test_read_conf_is_the_clis_conversion(self):
        poses = read_conf(BUNNY / "bun.conf")
        (qx, qy, qz, qw), t = poses["bun045.ply"]
        self.assertAlmostEqual(qx * qx + qy * qy + qz * qz + qw * qw, 1.0, places=12)
        line = next(l for l in (BUNNY / "bun.conf").read_text().splitlines()
                    if "bun045.ply" in l).split()
        self.assertEqual(t, tuple(map(float, line[2:5])))
        self.assertLess(qx * float(line[5]), 0)  # conjugated
        bad = self.tmp / "bad.conf"
        bad.write_text("bmesh a.ply 0 0 0 0 0 0\n")
        with self.assertRaisesRegex(ValueError, "bad.conf: line 1: expected 'bmesh <file>"):
            read_conf(bad)
        with self.assertRaisesRegex(ValueError, "has no pose for bun000.ply"):
            read_scans(BUNNY / "bun000.ply", conf={"other.ply": poses["bun045.ply"]})


if __name__ == "__main__":
    unittest.main()
