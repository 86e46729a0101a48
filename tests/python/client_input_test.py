# SPDX-License-Identifier: Apache-2.0
"""A wrongly shaped scan is refused by the client before anything is sent, with a ValueError that
names the scan and the field (issue 40 item 6: such arrays broke the request stream and surfaced
as `UNKNOWN: Exception iterating requests!`). Against a real scanprep-server ($SCANPREP_SERVER),
so that a mistake that slipped past the checks would show as the server's or gRPC's error."""

import unittest

import numpy as np

from scanprep_client import Client, Scan

from local_server import LocalServer


def plane(n=400):
    u, v = np.meshgrid(np.arange(20) * 0.5, np.arange(n // 20) * 0.5)
    return np.column_stack([u.ravel(), v.ravel(), np.zeros(u.size)]).astype(np.float32)


class InputChecksTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = cls.enterClassContext(LocalServer())
        cls.client = cls.enterClassContext(Client(cls.server.target, timeout=30))

    def assert_refused(self, scans, pattern):
        with self.assertRaisesRegex(ValueError, pattern):
            self.client.process(scans, unit="mm", stages=["outliers"])

    def test_points_that_are_not_n_by_3(self):
        self.assert_refused([Scan(points=plane()), Scan(points=plane()[:, :2], scan_id="cam2")],
                            r"scan 1 \('cam2'\): points: shape \(400, 2\) \(expected n×3")
        self.assert_refused([Scan(points=plane().ravel(), scan_id="flat")],
                            r"scan 0 \('flat'\): points: shape \(1200,\)")

    def test_empty_and_unmeasured_only_points(self):
        self.assert_refused([Scan(points=np.zeros((0, 3), np.float32), scan_id="e")],
                            r"scan 0 \('e'\): points: empty")
        self.assert_refused([Scan(points=np.full((5, 3), np.nan), scan_id="n")],
                            r"scan 0 \('n'\): points: none of the 5 is finite")

    def test_per_point_arrays_of_another_length(self):
        points = plane()
        self.assert_refused([Scan(points=points, scan_id="s",
                                  scanline=np.zeros(len(points) - 1, np.uint32))],
                            r"scan 0 \('s'\): scanline: shape \(399,\) \(expected \(400,\)")
        self.assert_refused([Scan(points=points, scan_id="q", quality=np.ones((len(points), 2)))],
                            r"scan 0 \('q'\): quality: shape \(400, 2\)")
        self.assert_refused([Scan(points=points, scan_id="i", intensity=[1.0, 2.0])],
                            r"scan 0 \('i'\): intensity: shape \(2,\)")
        self.assert_refused([Scan(points=points, scan_id="neg",
                                  scanline=-np.ones(len(points), np.int64))],
                            r"scan 0 \('neg'\): scanline: values must be integers")

    def test_a_per_point_array_some_scans_lack(self):
        # The API takes an optional array in every chunk or in none: without the check the
        # stream broke (UNKNOWN: Exception iterating requests!).
        for name in ("scanline", "quality", "intensity"):
            given = Scan(points=plane(), scan_id="with", **{name: np.ones(400, np.uint32)})
            self.assert_refused([given, Scan(points=plane(), scan_id="without")],
                                rf"scan 1 \('without'\): {name}: None, but scan 0 has it")

    def test_vectors_and_poses(self):
        self.assert_refused([Scan(points=plane(), scan_id="v", view_direction=(0, 1))],
                            r"scan 0 \('v'\): view_direction")
        # A .conf line's seven numbers are not a to_common (read_conf converts them).
        self.assert_refused([Scan(points=plane(), scan_id="c",
                                  to_common=(0.1, 0, 0, 0, 0, 0, 1))],
                            r"scan 0 \('c'\): to_common: .*read_conf")

    def test_a_scan_instead_of_a_list(self):
        self.assert_refused(Scan(points=plane(), scan_id="one"), r"scans: a sequence of Scan")

    def test_a_good_scan_still_goes_through(self):
        points = plane()
        result = self.client.process([Scan(points=points, scan_id="ok",
                                           scanline=np.repeat(np.arange(20), 20))],
                                     unit="mm", stages=["outliers"])
        self.assertEqual(result.typed_report.points_received, len(points))


if __name__ == "__main__":
    unittest.main()
