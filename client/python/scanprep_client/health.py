# SPDX-License-Identifier: Apache-2.0
"""The report's scanner health (Report.health, issue 32) as typed values: per scan its noise and
shares, per overlapping pair its point-to-plane residual and rigid misalignment. Lengths are in
millimetres and angles in degrees, as the report states them; a value the service did not measure
is None, and so is a misalignment component the overlap cannot constrain (the wire sends it as 0,
which would read as "aligned")."""

from __future__ import annotations

import dataclasses
from typing import Optional

from scanprep.v1 import scanprep_pb2 as pb

AXES = ("tx", "ty", "tz", "rx", "ry", "rz")  # PairHealth.unconstrained's names

Vector = tuple[Optional[float], Optional[float], Optional[float]]


@dataclasses.dataclass(frozen=True)
class ScanHealth:
    scan_id: str
    sensor_id: str                         # "" when the job did not name the sensor
    points: int                            # the scan's points that entered the pipeline
    noise_mm: Optional[float]              # σ̂, the median RMS residual of its normal fits
    noise_to_uncertainty: Optional[float]  # σ̂ / u; None without a stated u
    outlier_share: Optional[float]         # of `points`; None when the stage did not run
    merged_share: Optional[float]
    invalid_share: float                   # of the received points: NaN/Inf
    viewing_angle_deg: Optional[tuple[float, float, float]]  # p10, p50, p90; None without a pose


@dataclasses.dataclass(frozen=True)
class PairHealth:
    fixed_scan_id: str
    moving_scan_id: str
    fixed_sensor_id: str
    moving_sensor_id: str
    overlap_points: int
    residual_median_mm: float   # signed distance of moving's points to fixed's local planes
    residual_spread_mm: float   # 1.4826 · MAD
    translation_mm: Vector      # moving relative to fixed; None = unconstrained
    rotation_deg: Vector        # about x, y, z through `centre`; None = unconstrained
    # Each component's standard error (mm; degrees), unconstrained ones too; inf where the
    # overlap holds nothing along it. A constrained component lies within two of them of the truth
    # in 95 % of simulated cases.
    translation_se_mm: tuple[float, float, float]
    rotation_se_deg: tuple[float, float, float]
    centre: tuple[float, float, float]
    unconstrained: tuple[str, ...]  # of AXES
    note: str                       # why a component is unconstrained


@dataclasses.dataclass(frozen=True)
class Health:
    scans: tuple[ScanHealth, ...]
    pairs: tuple[PairHealth, ...]


def _optional(message, field: str) -> Optional[float]:
    return getattr(message, field) if message.HasField(field) else None


def _components(pair: pb.PairHealth, vector: pb.Vec3, prefix: str) -> Vector:
    free = set(pair.unconstrained)
    return tuple(None if prefix + axis in free else getattr(vector, axis)  # type: ignore
                 for axis in "xyz")


def _xyz(vector: pb.Vec3) -> tuple[float, float, float]:
    return (vector.x, vector.y, vector.z)


def _scan(s: pb.ScanHealth) -> ScanHealth:
    angles = tuple(s.viewing_angle_percentiles_deg)
    return ScanHealth(
        scan_id=s.scan_id, sensor_id=s.sensor_id, points=s.points,
        noise_mm=_optional(s, "noise_mm"),
        noise_to_uncertainty=_optional(s, "noise_to_uncertainty"),
        outlier_share=_optional(s, "outlier_share"), merged_share=_optional(s, "merged_share"),
        invalid_share=s.invalid_share,
        viewing_angle_deg=angles if len(angles) == 3 else None)  # type: ignore[arg-type]


def _pair(p: pb.PairHealth) -> PairHealth:
    return PairHealth(
        fixed_scan_id=p.fixed_scan_id, moving_scan_id=p.moving_scan_id,
        fixed_sensor_id=p.fixed_sensor_id, moving_sensor_id=p.moving_sensor_id,
        overlap_points=p.overlap_points, residual_median_mm=p.residual_median_mm,
        residual_spread_mm=p.residual_spread_mm,
        translation_mm=_components(p, p.translation_mm, "t"),
        rotation_deg=_components(p, p.rotation_deg, "r"),
        translation_se_mm=_xyz(p.translation_se_mm), rotation_se_deg=_xyz(p.rotation_se_deg),
        centre=_xyz(p.centre),
        unconstrained=tuple(p.unconstrained), note=p.note)


def health_from_report(report: pb.Report) -> Optional[Health]:
    """The report's health, or None when the job did not run the "health" stage."""
    if not report.HasField("health"):
        return None
    return Health(scans=tuple(_scan(s) for s in report.health.scans),
                  pairs=tuple(_pair(p) for p in report.health.pairs))
