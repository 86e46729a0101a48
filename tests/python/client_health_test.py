# SPDX-License-Identifier: Apache-2.0
"""The Python client's scanner health (issue 32): Result.health from a hand-made Report (units,
unset values and unconstrained components as None) and the typed report's registration from one,
and against a real scanprep-server ($SCANPREP_SERVER) two overlapping planes from two named
sensors, one raised by a known step."""

import os
import unittest

import numpy as np

from scanprep.v1 import scanprep_pb2 as pb
from scanprep_client import Client, Result, Scan, ScanRegistration

from local_server import LocalServer


def result_with(report: pb.Report) -> Result:
    empty = np.zeros((0, 3), dtype=np.float32)
    return Result(points=empty, normals=None, flags=np.zeros(0, dtype=np.uint8),
                  scan_index=np.zeros(0, dtype=np.uint32), report=report)


class HealthFromReportTest(unittest.TestCase):
    def test_values_unset_values_and_unconstrained_components(self):
        report = pb.Report()
        scan = report.health.scans.add(scan_id="left", sensor_id="cell3-left", points=40256,
                                       noise_mm=0.0123, invalid_share=0.001)
        scan.viewing_angle_percentiles_deg.extend([12.0, 35.0, 61.0])
        report.health.scans.add(scan_id="right", points=7)
        pair = report.health.pairs.add(fixed_scan_id="left", moving_scan_id="right",
                                       overlap_points=5321, residual_median_mm=-0.0042,
                                       residual_spread_mm=0.0105, note="too flat to constrain tz")
        pair.translation_mm.x, pair.translation_mm.y = 0.002, -0.0155
        pair.rotation_deg.x = 0.0125
        pair.translation_se_mm.x, pair.translation_se_mm.z = 0.0001, 0.0042
        pair.rotation_se_deg.y = float("inf")
        pair.unconstrained.extend(["tz", "ry"])

        health = result_with(report).health
        left, right = health.scans
        self.assertEqual((left.scan_id, left.sensor_id, left.points), ("left", "cell3-left", 40256))
        self.assertAlmostEqual(left.noise_mm, 0.0123)
        self.assertIsNone(left.noise_to_uncertainty)  # unset is not 0
        self.assertIsNone(left.outlier_share)
        self.assertEqual(left.viewing_angle_deg, (12.0, 35.0, 61.0))
        self.assertIsNone(right.noise_mm)
        self.assertIsNone(right.viewing_angle_deg)
        (p,) = health.pairs
        self.assertEqual((p.fixed_scan_id, p.moving_scan_id, p.overlap_points),
                         ("left", "right", 5321))
        self.assertAlmostEqual(p.residual_median_mm, -0.0042)
        self.assertEqual(p.translation_mm, (0.002, -0.0155, None))  # tz unconstrained
        self.assertEqual(p.rotation_deg, (0.0125, None, 0.0))       # ry unconstrained
        self.assertEqual(p.translation_se_mm, (0.0001, 0.0, 0.0042))  # tz's too
        self.assertEqual(p.rotation_se_deg, (0.0, float("inf"), 0.0))
        self.assertEqual(p.unconstrained, ("tz", "ry"))
        self.assertEqual(p.note, "too flat to constrain tz")

    def test_a_report_without_health_has_none(self):
        self.assertIsNone(result_with(pb.Report()).health)


class RegistrationFromReportTest(unittest.TestCase):
    def test_every_field_of_a_reference_and_a_moved_scan(self):
        report = pb.Report()
        report.registration.add(scan_id="336", reference=True, constrained_directions=6,
                                residual_before_mm=0.186, residual_after_mm=0.097, iterations=9)
        report.registration.add(scan_id="24", translation_mm=pb.Vec3(x=0.012, y=-0.034, z=0.056),
                                rotation_deg=pb.Vec3(x=0.01, y=-0.02, z=0.03),
                                centre=pb.Vec3(x=-12.5, y=40.25, z=310.0),
                                constrained_directions=5, residual_before_mm=0.221,
                                residual_after_mm=0.130, iterations=7, bound_exceeded=False)

        reference, scan = result_with(report).typed_report.registration
        self.assertEqual(reference, ScanRegistration(
            scan_id="336", reference=True, translation_mm=(0.0, 0.0, 0.0),
            rotation_deg=(0.0, 0.0, 0.0), centre=(0.0, 0.0, 0.0), constrained_directions=6,
            residual_before_mm=0.186, residual_after_mm=0.097, iterations=9,
            bound_exceeded=False))
        self.assertEqual(scan, ScanRegistration(
            scan_id="24", reference=False, translation_mm=(0.012, -0.034, 0.056),
            rotation_deg=(0.01, -0.02, 0.03), centre=(-12.5, 40.25, 310.0),
            constrained_directions=5, residual_before_mm=0.221, residual_after_mm=0.130,
            iterations=7, bound_exceeded=False))

    def test_a_scan_put_back_says_so(self):
        report = pb.Report()
        report.registration.add(scan_id="far", bound_exceeded=True)
        (scan,) = result_with(report).typed_report.registration
        self.assertTrue(scan.bound_exceeded)
        # Nothing measured is None, not a residual of 0 (which would read as a perfect fit).
        self.assertIsNone(scan.residual_before_mm)
        self.assertIsNone(scan.residual_after_mm)

    def test_a_report_without_registration_has_an_empty_tuple(self):
        self.assertEqual(result_with(pb.Report()).typed_report.registration, ())


def plane(seed: int, z: float) -> np.ndarray:
    """A 60 mm square plane at height z: 120 scanlines of 120 points 0.5 mm apart, 5 µm noise."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.arange(120) * 0.5, np.arange(120) * 0.5)
    return np.column_stack([u.ravel(), v.ravel(), z + rng.normal(0, 0.005, u.size)])


@unittest.skipUnless(os.environ.get("SCANPREP_SERVER"), "SCANPREP_SERVER not set")
class HealthFromServerTest(unittest.TestCase):
    def test_two_sensors_one_raised_by_20_um(self):
        step_mm = 0.020
        scanline = np.repeat(np.arange(120, dtype=np.uint32), 120)
        scans = [Scan(points=plane(seed, z).astype(np.float32), scan_id=name, sensor_id=sensor,
                      camera_position=(30, 30, 300), scanline_spacing=0.5, point_spacing=0.5,
                      uncertainty=0.005, scanline=scanline)
                 for seed, z, name, sensor in [(1, 0.0, "a", "cell-a"), (2, step_mm, "b", "cell-b")]]
        with LocalServer() as server, Client(server.target) as client:
            returned = []  # the points each job brought back
            process = client.process

            def counting(*args, **kwargs):
                result = process(*args, **kwargs)
                returned.append(len(result.points))
                return result
            client.process = counting
            health = client.health(scans, unit="mm", timeout=120)
        # Issue 40: health downloaded the whole cloud it never used; now the report alone comes.
        self.assertEqual(returned, [0])
        self.assertEqual([(s.scan_id, s.sensor_id, s.points) for s in health.scans],
                         [("a", "cell-a", 14400), ("b", "cell-b", 14400)])
        for s in health.scans:  # σ̂ of 5 µm noise, stated as u = 5 µm
            self.assertAlmostEqual(s.noise_mm, 0.005, delta=0.0015)
            self.assertAlmostEqual(s.noise_to_uncertainty, 1.0, delta=0.3)
        (pair,) = health.pairs
        self.assertEqual((pair.fixed_sensor_id, pair.moving_sensor_id), ("cell-a", "cell-b"))
        self.assertGreater(pair.overlap_points, 10000)
        # b lies 20 µm above a along a's normal (toward the camera): the residual and tz say so.
        self.assertAlmostEqual(pair.residual_median_mm, step_mm, delta=0.003)
        self.assertAlmostEqual(pair.translation_mm[2], step_mm, delta=0.004)
        # Known to a fraction of a µm (28,800 points of 5 µm noise), within its two errors.
        self.assertLess(pair.translation_se_mm[2], 0.0005)
        self.assertAlmostEqual(pair.translation_mm[2], step_mm, delta=2 * pair.translation_se_mm[2])
        # A plane cannot fix a slide within itself nor a turn about its normal.
        self.assertTrue({"tx", "ty", "rz"} <= set(pair.unconstrained), pair.unconstrained)
        self.assertEqual(pair.translation_mm[:2], (None, None))


if __name__ == "__main__":
    unittest.main()
