# SPDX-License-Identifier: Apache-2.0
"""The report's registration (Report.registration) as typed values: per scan that overlaps another
enough to be measured, the rigid motion the "registration" stage applied and its residual before
and after (docs/health.md, Registration). Lengths are in millimetres and angles in degrees, as the
report states them."""

from __future__ import annotations

import dataclasses
from typing import Optional

from scanprep.v1 import scanprep_pb2 as pb

from scanprep_client.health import _optional, _xyz


@dataclasses.dataclass(frozen=True)
class ScanRegistration:
    scan_id: str
    reference: bool  # held where it is: the scan with the most points of its overlapping group
    # The motion applied to the scan's points, normals and pose: a rotation by the rotation vector
    # `rotation_deg` about `centre` (common frame, mm, relative to the job's origin), then a
    # translation by `translation_mm`.
    translation_mm: tuple[float, float, float]
    rotation_deg: tuple[float, float, float]
    centre: tuple[float, float, float]
    # The directions of its motion (of six) its overlaps constrain; it moved along these only.
    constrained_directions: int
    # Robust RMS distance of its points from the other scans' local planes, before the first step
    # and after the last; None where no other scan overlaps it enough to measure.
    residual_before_mm: Optional[float]
    residual_after_mm: Optional[float]
    iterations: int  # steps applied
    # The correction it needed exceeded registration.max_correction: left where it was (warning
    # REGISTRATION_BOUND_EXCEEDED).
    bound_exceeded: bool


def registration_from_report(report: pb.Report) -> tuple[ScanRegistration, ...]:
    """The report's registration in scan order; empty when the job did not run the "registration"
    stage."""
    return tuple(ScanRegistration(
        scan_id=r.scan_id, reference=r.reference, translation_mm=_xyz(r.translation_mm),
        rotation_deg=_xyz(r.rotation_deg), centre=_xyz(r.centre),
        constrained_directions=r.constrained_directions,
        residual_before_mm=_optional(r, "residual_before_mm"),
        residual_after_mm=_optional(r, "residual_after_mm"),
        iterations=r.iterations, bound_exceeded=r.bound_exceeded)
        for r in report.registration)
