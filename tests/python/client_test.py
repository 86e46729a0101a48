# SPDX-License-Identifier: Apache-2.0
"""The Python client (client/python) against a real scanprep-server: the bunny scans from
../shared/data, a plane with known spikes, and a refused parameter. Run by ctest with the venv
that python_client_install made (the installed package) and SCANPREP_SERVER set
(tests/CMakeLists.txt)."""

import os
import pathlib
import unittest

import grpc
import numpy as np

from scanprep_client import STRICT_WARNING_CODES, Client, Flag, Scan, ScanprepError, read_scan
from scanprep.v1 import scanprep_pb2 as pb

from local_server import LocalServer

DATA = pathlib.Path(os.environ.get(
    "SCANPREP_DATA_DIR", pathlib.Path(__file__).resolve().parents[2].parent / "shared" / "data"))


def bunny_scan(name: str) -> Scan:
    """A bunny range scan (its range_grid rows as scanlines) posed by bun.conf, as `scanprep
    process --conf` poses it (read_conf: the file stores Rᵀ)."""
    folder = DATA / "stanford_bunny_range_scans"
    return read_scan(folder / f"{name}.ply", conf=folder / "bun.conf")


def spiky_plane():
    """A 74.5 mm square plane (150 scanlines of 150 points, 0.5 mm apart, 0.01 mm noise) with 100
    spikes 2-5 mm above it: the points (float64), each point's scanline, the spikes' indices."""
    rng = np.random.default_rng(7)
    u, v = np.meshgrid(np.arange(150) * 0.5, np.arange(150) * 0.5)
    plane = np.column_stack([u.ravel(), v.ravel(), rng.normal(0, 0.01, u.size)])
    spikes = rng.choice(u.size, 100, replace=False)
    plane[spikes, 2] += rng.uniform(2, 5, spikes.size)
    return plane, np.repeat(np.arange(150, dtype=np.uint32), 150), spikes


class ClientTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        server = cls.enterClassContext(LocalServer())
        cls.client = cls.enterClassContext(Client(server.target))

    def test_bunny_scans_in_one_job(self):
        if not (DATA / "stanford_bunny_range_scans" / "bun.conf").exists():
            self.skipTest(f"real-scan data folder {DATA} not found (set SCANPREP_DATA_DIR)")
        scans = [bunny_scan("bun000"), bunny_scan("bun045")]
        sent = sum(len(s.points) for s in scans)
        result = self.client.process(scans, unit="m", labels={"part_serial": "bunny-1"},
                                     include_removed=True, timeout=120)
        report = result.report
        self.assertEqual(report.points_received, sent)
        self.assertEqual(len(result.points), sent)            # include_removed: all of them
        self.assertEqual(report.labels["part_serial"], "bunny-1")
        # Every point keeps its scan, in the order sent.
        np.testing.assert_array_equal(result.scan_index,
                                      np.repeat([0, 1], [len(s.points) for s in scans]))
        kept = result.kept
        self.assertEqual(int(kept.sum()), report.stages[-1].points_out)
        # The bunny is about 0.155 × 0.15 × 0.12 m: the merged cloud stays that size.
        extent = np.ptp(result.points[kept], axis=0)
        self.assertTrue(np.all(extent < 0.2) and np.all(extent > 0.05), extent)
        # Unit normals wherever a normal was fitted.
        valid = kept & ((result.flags & int(Flag.NORMAL_INVALID)) == 0)
        norms = np.linalg.norm(result.normals[valid], axis=1)
        self.assertLess(np.abs(norms - 1).max(), 1e-4)
        outliers = np.count_nonzero(result.flags & int(Flag.REMOVED_OUTLIER))
        self.assertLess(outliers, 0.05 * sent)

    def test_spikes_on_a_plane_are_flagged_and_the_rest_comes_back_unchanged(self):
        plane, rows, spikes = spiky_plane()
        scan = Scan(points=plane.astype(np.float32), scanline=rows, scanline_spacing=0.5,
                    view_direction=(0, 0, 1), uncertainty=0.01)
        result = self.client.process([scan], unit="mm", stages=["outliers"],
                                     include_removed=True, chunk_points=4000)
        # float32 near zero: no offset, no origin, float32 back, as before origins existed.
        self.assertIsNone(result.origin)
        self.assertEqual(result.points.dtype, np.float32)
        np.testing.assert_array_equal(result.points, scan.points)
        removed = set(np.flatnonzero(result.flags & int(Flag.REMOVED_OUTLIER)))
        self.assertLessEqual(set(spikes), removed)                # every spike
        self.assertLessEqual(len(removed - set(spikes)), 0.001 * len(plane))  # ≤ 0.1 % of it

    def test_a_scan_far_from_zero_gives_the_same_result_as_at_zero(self):
        # Centred on zero, so that the far copy's local origin is its offset exactly, and on a
        # 2^-20 mm grid, so that double holds it exactly at 1e7 mm too: both jobs then see the same
        # local points, and the whole pipeline must agree to 1e-4 mm. Sent as float32 at 1e7 mm
        # the scan would sit on a 1 mm lattice.
        plane, rows, _ = spiky_plane()
        centred = np.round((plane - [37.25, 37.25, 0]) * 2**20) / 2**20
        far = np.array([1e7, -1e7, 5e6])
        results = []
        for offset in (np.zeros(3), far):
            scan = Scan(points=centred + offset, scanline=rows, scanline_spacing=0.5,
                        view_direction=(0, 0, 1), uncertainty=0.01)
            results.append(self.client.process([scan], unit="mm", include_removed=True,
                                               timeout=120))
        near, distant = results
        self.assertIsNone(near.origin)  # float64 near zero: sent as it always was
        np.testing.assert_array_equal(distant.origin, far)
        self.assertEqual(distant.points.dtype, np.float64)
        np.testing.assert_array_equal(distant.flags, near.flags)
        self.assertGreater(np.count_nonzero(near.flags & int(Flag.SMOOTHED)), 0)
        self.assertLessEqual(np.abs((distant.points - far) - near.points).max(), 1e-4)

    def test_far_points_come_back_in_the_callers_coordinates(self):
        # 45° about z into the common frame: the job's origin is the offset turned likewise, and
        # the returned points are the sent ones turned (outliers moves none), to 1e-4 mm.
        plane, rows, spikes = spiky_plane()
        points = plane + [5e8, 1e7, -3e6]
        c = s = np.sqrt(0.5)
        turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        scan = Scan(points=points, scanline=rows, scanline_spacing=0.5, view_direction=(0, 0, 1),
                    uncertainty=0.01, to_common=((0, 0, np.sin(np.pi / 8), np.cos(np.pi / 8)),
                                                 (100, 200, 300)))
        result = self.client.process([scan], unit="mm", stages=["outliers"], include_removed=True)
        expected = points @ turn.T + [100, 200, 300]
        self.assertEqual(result.points.dtype, np.float64)
        self.assertLessEqual(np.abs(result.points - expected).max(), 1e-4)
        self.assertLessEqual(set(spikes), set(np.flatnonzero(result.flags & int(Flag.REMOVED))))
        # The caller's own origin near the turned data: the same points, relative to it on the way.
        mine = (346_482_400, 360_624_700, -2_999_700)
        given = self.client.process([scan], unit="mm", stages=["outliers"], include_removed=True,
                                    origin=mine)
        np.testing.assert_array_equal(given.origin, mine)
        self.assertLessEqual(np.abs(given.points - expected).max(), 1e-4)

    def test_a_preset_sets_its_parameters_and_params_override_it(self):
        plane, rows, _ = spiky_plane()
        scan = Scan(points=plane.astype(np.float32), scanline=rows, scanline_spacing=0.5,
                    view_direction=(0, 0, 1), uncertainty=0.01)
        result = self.client.process([scan], unit="mm", stages=["outliers"], preset="paper",
                                     params={"outliers.multiplier": 3})
        self.assertEqual(result.report.preset, "paper")
        used = next(s for s in result.report.stages if s.name == "outliers").parameters
        self.assertEqual(used["outliers.surface_sigmas"], 0)  # the paper's: no surface test
        self.assertEqual(used["outliers.multiplier"], 3)      # the job's own value wins

    def test_a_refused_parameter_names_its_field(self):
        scan = Scan(points=np.zeros((10, 3), dtype=np.float32))
        with self.assertRaises(ScanprepError) as caught:
            self.client.process([scan], unit="mm", params={"smoothing.lambda": 7})
        error = caught.exception
        self.assertEqual(error.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertEqual(error.field, "header.options.params['smoothing.lambda']")
        self.assertTrue(error.reason)

    def test_info(self):
        info = self.client.info()
        self.assertTrue(info.version)
        self.assertGreater(info.limits.max_points_per_job, 0)
        self.assertEqual([pb.WarningCode.Name(c)[len("WARNING_CODE_"):]
                          for c in info.strict_warning_codes], list(STRICT_WARNING_CODES))

    def test_strict_fails_a_job_whose_unit_cannot_be_checked(self):
        """A scan stating no spacing and no uncertainty: its unit is unchecked (UNIT_UNCHECKED),
        which strict fails on; the control, without strict, runs; fail_on names one code."""
        plane, scanlines, _ = spiky_plane()
        bare = Scan(points=plane, scanline=scanlines)
        self.assertGreater(len(self.client.process([bare], unit="mm", stages=["normals"]).points),
                           0)
        for options in ({"strict": True}, {"fail_on": ["UNIT_UNCHECKED"]}):
            with self.assertRaises(ScanprepError) as caught:
                self.client.process([bare], unit="mm", stages=["normals"], **options)
            self.assertEqual(caught.exception.code, grpc.StatusCode.FAILED_PRECONDITION)
            self.assertEqual(caught.exception.reason, "UNIT_UNCHECKED")
        stated = Scan(points=plane, scanline=scanlines, scanline_spacing=0.5, uncertainty=0.01)
        self.client.process([stated], unit="mm", stages=["normals"], strict=True)
        with self.assertRaises(ValueError):
            self.client.process([bare], unit="mm", fail_on=["NO_SUCH_CODE"])


if __name__ == "__main__":
    unittest.main()
