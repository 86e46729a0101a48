# SPDX-License-Identifier: Apache-2.0
"""Sends one job as packed little-endian arrays (PointChunk.*_packed) and reads the result the
same way: numpy's tobytes() and frombuffer(), no loop per value."""

from __future__ import annotations

import dataclasses
import enum
import warnings
import zlib
from typing import Callable, Iterator, Mapping, Optional, Sequence, TypeVar

import grpc
import numpy as np

from scanprep.v1 import scanprep_pb2 as pb
from scanprep.v1 import scanprep_pb2_grpc as pb_grpc
from scanprep_client.errors import ScanprepError, error_from_rpc
from scanprep_client.health import Health, health_from_report
from scanprep_client.report import Report, report_from_pb
from scanprep_client.retry import RetryPolicy, call_with_retries

_UNITS = {"mm": pb.LENGTH_UNIT_MILLIMETRE, "m": pb.LENGTH_UNIT_METRE, "um": pb.LENGTH_UNIT_MICROMETRE, "in": pb.LENGTH_UNIT_INCH}
_CHUNK_POINTS = 32768  # the service's recommended chunk size (GetInfo().limits)
# What process(strict=True) fails on: the service's GetInfo().strict_warning_codes, as the CLI's
# --strict (a test holds them equal).
STRICT_WARNING_CODES = ("UNIT_SUSPECT", "NOISE_ABOVE_UNCERTAINTY", "SCAN_REPEATED",
                        "POINTS_INVALID", "UNIT_UNCHECKED", "SCANLINES_IMPLAUSIBLE")
# The optional per-point arrays a scan sends and the result gives back (Result's fields by the same
# names), with their wire types.
_SCANNER_ARRAYS = {"scanline": "<u4", "quality": "<f4", "intensity": "<f4"}
T = TypeVar("T")


class Flag(enum.IntFlag):
    """Bits of Result.flags (scanprep.proto, enum Flag)."""
    REMOVED_OUTLIER = 1
    REMOVED_MERGE = 2
    REMOVED_SIMPLIFY = 4
    SMOOTHED = 8
    NORMAL_INVALID = 16
    EDGE = 32
    REMOVED = REMOVED_OUTLIER | REMOVED_MERGE | REMOVED_SIMPLIFY


@dataclasses.dataclass
class Scan:
    """One scan: points (n×3, in the job's unit, the scan's own frame) and what the scanner
    knows. Vectors are 3-sequences; to_common is (quaternion x, y, z, w; translation x, y, z).

    float32 points are sent as they are. Points of any other type (float64, integers) are read in
    double and sent relative to points_offset: the caller's, else a round origin near the data
    (local_origin), so a scan far from zero (a georeferenced survey, a plant grid) keeps its
    precision on the float wire. Points and positions are always absolute in the scan frame."""
    points: np.ndarray
    scan_id: str = ""
    sensor_id: str = ""  # the physical sensor, for its health across jobs ("" = not stated)
    camera_position: Optional[Sequence[float]] = None
    view_direction: Optional[Sequence[float]] = None
    projector_position: Optional[Sequence[float]] = None
    projector_direction: Optional[Sequence[float]] = None
    scanline_spacing: float = 0.0
    uncertainty: float = 0.0
    point_spacing: float = 0.0
    to_common: Optional[tuple[Sequence[float], Sequence[float]]] = None
    scanline: Optional[np.ndarray] = None   # uint32 per point
    quality: Optional[np.ndarray] = None    # float in [0, 1] per point
    intensity: Optional[np.ndarray] = None  # float per point
    points_offset: Optional[Sequence[float]] = None  # None = chosen (see above)
    points_unmeasured: int = 0  # points the file had without a position, left out (readers)
    # What the service does not read, by name, one value per point (first axis = the points): a
    # file's colour, a scanner's own scalars. Not sent; Result.attributes gives them back for the
    # returned points (by Result.source_index).
    attributes: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class Result:
    """The returned points in the job's unit and the common frame, with the service's report.
    With a job origin the service's local coordinates come back with it added, in float64."""
    points: np.ndarray               # n×3 float32, or float64 when origin is set
    normals: Optional[np.ndarray]    # n×3 float32, or None
    flags: np.ndarray                # uint8 per point (Flag bits)
    scan_index: np.ndarray           # uint32 per point
    report: pb.Report
    origin: Optional[np.ndarray] = None  # the job's origin (float64 × 3), None when it had none
    # Each returned point's 0-based position in the upload: over the scans' points in the order
    # given, unmeasured (NaN) rows counted. uint32; None when the job did not ask for it (no scan
    # had attributes and return_source_index was not given).
    source_index: Optional[np.ndarray] = None
    # The scans' attributes for the returned points, by name: those every scan of the job has with
    # one dtype (and shape per point); any other is left out with a warning.
    attributes: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    # The scanner's per-point arrays the job sent (Scan.scanline, .quality, .intensity), as the
    # service returns them for each returned point (PointChunk): carried through unchanged by
    # every stage. One value per point (0 values for a result of no point); None when the job's
    # scans had none, as normals is None when none came back.
    scanline: Optional[np.ndarray] = None    # uint32
    quality: Optional[np.ndarray] = None     # float32 in [0, 1], 1 = trustworthy
    intensity: Optional[np.ndarray] = None   # float32

    @property
    def kept(self) -> np.ndarray:
        """Mask of the points not removed (all of them unless include_removed was asked)."""
        return (self.flags & int(Flag.REMOVED)) == 0

    @property
    def typed_report(self) -> Report:
        """The report as typed, frozen dataclasses (scanprep_client.Report); `report` is the
        protobuf message itself."""
        return report_from_pb(self.report)

    @property
    def health(self) -> Optional[Health]:
        """The scans' and overlapping pairs' health; None when the "health" stage did not run."""
        return health_from_report(self.report)


def _vec(target, values) -> None:
    target.x, target.y, target.z = (float(v) for v in values)


def local_origin(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The origin for coordinates within [lo, hi], by the rule of the C++ readers
    (core/io/local_frame.cc): zero when the box's centre lies within 16 extents of zero (an
    ordinary scan is sent as before), else its centre rounded to a power of ten no larger than the
    extent, so local coordinates stay within about the extent and a round offset cancels exactly."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    centre = 0.5 * lo + 0.5 * hi
    extent = float(np.max(hi - lo))
    if not np.isfinite(extent) or not np.all(np.isfinite(centre)):
        return np.zeros(3)
    if np.max(np.abs(centre)) <= 16 * extent:  # float loses at most 5 of its 24 bits
        return np.zeros(3)
    if extent == 0:
        return centre
    step = 10.0 ** np.floor(np.log10(extent))
    # C++ std::round: halves away from zero (numpy's round goes to even).
    return np.copysign(np.floor(np.abs(centre / step) + 0.5), centre) * step


def _points_offset(scan: Scan) -> Optional[np.ndarray]:
    """What scan's points are sent relative to: the caller's offset, else for points that are
    not float32 the local origin of their finite ones; None when nothing is to be taken off."""
    if scan.points_offset is not None:
        return np.asarray(scan.points_offset, dtype=np.float64).reshape(3)
    points = np.asarray(scan.points)
    if points.dtype == np.float32 or points.size == 0:
        return None
    points = points.astype(np.float64, copy=False).reshape(-1, 3)
    finite = points[np.all(np.isfinite(points), axis=1)]
    if len(finite) == 0:
        return None
    origin = local_origin(finite.min(axis=0), finite.max(axis=0))
    return origin if np.any(origin != 0) else None


def _rotate(quaternion_xyzw: Sequence[float], v: np.ndarray) -> np.ndarray:
    """v turned by the (normalised) quaternion, in double, as Eigen's q * v."""
    q = np.asarray(quaternion_xyzw, dtype=np.float64)
    q = q / np.linalg.norm(q)
    u, w = q[:3], q[3]
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _wire_points(scan: Scan, offset: Optional[np.ndarray], index: int) -> np.ndarray:
    """scan's points as float32 relative to offset (subtracted in double). A finite point that
    float cannot hold is refused here, naming it, instead of travelling as infinity."""
    if offset is None:
        return np.asarray(scan.points, dtype="<f4").reshape(-1, 3)
    wide = np.asarray(scan.points, dtype=np.float64).reshape(-1, 3)
    local = (wide - offset).astype("<f4")
    lost = np.flatnonzero(np.any(np.isfinite(wide) & ~np.isfinite(local), axis=1))
    if len(lost):
        raise ValueError(f"scan {index} ({scan.scan_id!r}): point {lost[0]} "
                         f"{wide[lost[0]].tolist()} is beyond float's range from points_offset "
                         f"{offset.tolist()}")
    return local


def _vector_ok(value, length: int) -> bool:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return False
    return array.shape == (length,) and bool(np.all(np.isfinite(array)))


def check_scans(scans: Sequence[Scan]) -> None:
    """Raises ValueError naming the scan and the field for what the service could not take, before
    anything is sent (a wrongly shaped array would otherwise break the request stream and surface
    as gRPC's "Exception iterating requests!"): points that are not a non-empty n×3 numeric array
    with a finite point, per-point arrays (scanline, quality, intensity) of another length than the
    points or given for some scans only, scanlines that are not integers in [0, 2³²), vectors that
    are not 3 finite numbers, a to_common that is not ((qx, qy, qz, qw), (tx, ty, tz)), attributes
    that are not a dict of arrays with one value per point."""
    if isinstance(scans, Scan) or not all(isinstance(s, Scan) for s in scans):
        raise ValueError("scans: a sequence of Scan (one scan: [scan])")
    if not scans:
        raise ValueError("scans: no scan given")
    for i, scan in enumerate(scans):
        where = f"scan {i} ({scan.scan_id!r})"
        try:
            points = np.asarray(scan.points)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{where}: points: not an array of numbers ({e})") from None
        if points.dtype.kind not in "fiu":
            raise ValueError(f"{where}: points: dtype {points.dtype} (expected float or integer)")
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"{where}: points: shape {points.shape} (expected n×3: x, y, z "
                             "per row)")
        if len(points) == 0:
            raise ValueError(f"{where}: points: empty (a scan needs at least one point)")
        if points.dtype.kind == "f" and not np.any(np.all(np.isfinite(points), axis=1)):
            raise ValueError(f"{where}: points: none of the {len(points)} is finite (NaN or "
                             "infinite coordinates are unmeasured points)")
        for name in ("scanline", "quality", "intensity"):
            values = getattr(scan, name)
            if values is None:
                continue
            try:
                values = np.asarray(values)
            except (TypeError, ValueError) as e:
                raise ValueError(f"{where}: {name}: not an array ({e})") from None
            if values.shape != (len(points),):
                raise ValueError(f"{where}: {name}: shape {values.shape} (expected "
                                 f"({len(points)},), one value per point)")
            if values.dtype.kind not in "fiub":
                raise ValueError(f"{where}: {name}: dtype {values.dtype} (expected numbers)")
            if name == "scanline" and not np.all(
                    (values >= 0) & (values < 2 ** 32) & (values == np.floor(values))):
                raise ValueError(f"{where}: scanline: values must be integers in [0, 2^32)")
        for name in ("camera_position", "view_direction", "projector_position",
                     "projector_direction", "points_offset"):
            value = getattr(scan, name)
            if value is not None and not _vector_ok(value, 3):
                raise ValueError(f"{where}: {name}: {value!r} (expected 3 finite numbers)")
        if scan.to_common is not None:
            pose = scan.to_common
            if not (isinstance(pose, (tuple, list)) and len(pose) == 2 and
                    _vector_ok(pose[0], 4) and _vector_ok(pose[1], 3)):
                raise ValueError(f"{where}: to_common: {pose!r} (expected ((qx, qy, qz, qw), "
                                 "(tx, ty, tz)); a .conf pose: read_conf)")
        if not isinstance(scan.points_unmeasured, (int, np.integer)) or scan.points_unmeasured < 0:
            raise ValueError(f"{where}: points_unmeasured: {scan.points_unmeasured!r} (expected "
                             "a count)")
        _check_attributes(scan.attributes, len(points), where)
    for name in _SCANNER_ARRAYS:  # every chunk carries the array or none does (as the API)
        given = [getattr(scan, name) is not None for scan in scans]
        if any(given) and not all(given):
            i = given.index(False)
            raise ValueError(f"scan {i} ({scans[i].scan_id!r}): {name}: None, but scan "
                             f"{given.index(True)} has it (every scan of a job has it or none)")


def _check_attributes(attributes, count: int, where: str) -> None:
    if not isinstance(attributes, Mapping):
        raise ValueError(f"{where}: attributes: {type(attributes).__name__} (expected a dict of "
                         "name: array)")
    for name, values in attributes.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"{where}: attributes: name {name!r} (expected a non-empty str)")
        try:
            values = np.asarray(values)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{where}: attributes[{name!r}]: not an array ({e})") from None
        if values.ndim == 0 or values.shape[0] != count:
            raise ValueError(f"{where}: attributes[{name!r}]: shape {values.shape} (expected "
                             f"({count}, ...), one value per point)")


def _header(scans: Sequence[Scan], offsets: Sequence[Optional[np.ndarray]], origin, unit: str,
            stages, params, preset, include_removed, labels, budget_seconds,
            job_id, fail_on, result_arrays, return_source_index: bool = False) -> pb.JobHeader:
    if unit not in _UNITS:
        raise ValueError(f"unit {unit!r}: one of {sorted(_UNITS)}")
    header = pb.JobHeader(job_id=job_id, unit=_UNITS[unit],
                          result_arrays=result_arrays,
                          total_points=sum(len(s.points) for s in scans),
                          return_source_index=return_source_index)
    for scan, offset in zip(scans, offsets):
        s = header.scans.add(scan_id=scan.scan_id, sensor_id=scan.sensor_id,
                             scanline_spacing=scan.scanline_spacing,
                             uncertainty=scan.uncertainty, point_spacing=scan.point_spacing,
                             points_unmeasured=scan.points_unmeasured)
        for name in ("camera_position", "view_direction", "projector_position",
                     "projector_direction"):
            if getattr(scan, name) is not None:
                _vec(getattr(s, name), getattr(scan, name))
        if scan.to_common is not None:
            (qx, qy, qz, qw), translation = scan.to_common
            s.to_common.rotation.x, s.to_common.rotation.y = qx, qy
            s.to_common.rotation.z, s.to_common.rotation.w = qz, qw
            _vec(s.to_common.translation, translation)
        if offset is not None:
            _vec(s.points_offset, offset)
    if origin is not None:
        _vec(header.origin, origin)
    header.options.stages.extend(stages or [])
    header.options.params.update({k: str(v) for k, v in (params or {}).items()})
    header.options.preset = preset
    header.options.include_removed = include_removed
    for code in fail_on:
        if code not in pb.WarningCode.keys() or code == "WARNING_CODE_UNSPECIFIED":
            raise ValueError(f"fail_on: unknown warning code {code!r} (docs/api.md#warnings)")
        header.options.fail_on.append(pb.WarningCode.Value(code))
    header.labels.update(labels or {})
    header.budget.total_seconds = budget_seconds
    return header


def _column(scans: Sequence[Scan], name: str, dtype: str) -> Optional[np.ndarray]:
    """One optional per-point array over all scans; every scan must have it or none."""
    present = [getattr(s, name) is not None for s in scans]
    if not any(present):
        return None
    if not all(present):
        raise ValueError(f"{name}: given for some scans but not all (the service needs it in "
                         "every chunk or none)")
    return np.concatenate([np.asarray(getattr(s, name), dtype=dtype).ravel() for s in scans])


def _job_origin(scans: Sequence[Scan],
                offsets: Sequence[Optional[np.ndarray]]) -> Optional[np.ndarray]:
    """As the C++ client (SetJobOrigin): the first scan with an offset gives the job's origin,
    that offset moved into the common frame by the scan's to_common; no offset, no origin."""
    for scan, offset in zip(scans, offsets):
        if offset is None:
            continue
        if scan.to_common is None:
            return offset
        rotation, translation = scan.to_common
        return _rotate(rotation, offset) + np.asarray(translation, dtype=np.float64)
    return None


def _attribute_kind(values) -> tuple[np.dtype, tuple[int, ...]]:
    """An attribute's dtype (native byte order: a big-endian file's float32 is float32) and its
    shape per point."""
    values = np.asarray(values)
    return values.dtype.newbyteorder("="), values.shape[1:]


def _shared_attributes(scans: Sequence[Scan]) -> list[str]:
    """The attribute names that every scan has with one dtype and shape per point, in order of
    first appearance; a warning names each other one and why it will not come back."""
    def where(i: int) -> str:
        return f"scan {i} ({scans[i].scan_id!r})"

    shared, left_out = [], []
    for name in dict.fromkeys(n for s in scans for n in s.attributes):
        missing = next((i for i, s in enumerate(scans) if name not in s.attributes), None)
        if missing is not None:
            left_out.append(f"{name!r} ({where(missing)} has none)")
            continue
        kinds = [_attribute_kind(s.attributes[name]) for s in scans]
        other = next((i for i, k in enumerate(kinds) if k != kinds[0]), None)
        if other is not None:
            text = [f"{d}{f' × {shape}' if shape else ''}"
                    for d, shape in (kinds[0], kinds[other])]
            left_out.append(f"{name!r} ({text[0]} in {where(0)}, {text[1]} in {where(other)})")
            continue
        shared.append(name)
    if left_out:
        warnings.warn("Result.attributes: left out " + "; ".join(left_out) + ": an attribute "
                      "comes back only when every scan of the job has it, with one dtype",
                      stacklevel=3)
    return shared


def _gather(scans: Sequence[Scan], names: Sequence[str],
            source_index: np.ndarray) -> dict[str, np.ndarray]:
    """The named attributes of the returned points: their values over the scans in upload order
    (as _requests sends the points), taken at source_index."""
    gathered = {}
    for name in names:
        values = np.concatenate([np.asarray(s.attributes[name]) for s in scans])
        gathered[name] = values[source_index].astype(_attribute_kind(values)[0], copy=False)
    return gathered


def _requests(header: pb.JobHeader, scans: Sequence[Scan], offsets: Sequence[Optional[np.ndarray]],
              chunk_points: int) -> Iterator[pb.ProcessRequest]:
    xyz = np.concatenate([_wire_points(s, o, i) for i, (s, o) in enumerate(zip(scans, offsets))])
    arrays = {"xyz": xyz,
              "scan_index": np.concatenate([np.full(len(s.points), i, dtype="<u4")
                                            for i, s in enumerate(scans)]),
              "scanline": _column(scans, "scanline", "<u4"),
              "quality": _column(scans, "quality", "<f4"),
              "intensity": _column(scans, "intensity", "<f4")}
    yield pb.ProcessRequest(header=header)
    crc = 0
    for begin in range(0, len(xyz), chunk_points):
        chunk = pb.PointChunk()
        for name, values in arrays.items():  # field order: the checksum's order
            if values is None:
                continue
            data = values[begin:begin + chunk_points].tobytes()
            setattr(chunk, f"{name}_packed", data)
            crc = zlib.crc32(data, crc)
        yield pb.ProcessRequest(points=chunk)
    yield pb.ProcessRequest(end=pb.StreamEnd(points=len(xyz), crc32=crc))


class Client:
    """A channel to one scanprep server (or a load-balanced name).

    Every call has a deadline, timeout seconds unless the call names its own, shared by all its
    attempts; a call the service asks to repeat (RetryInfo: queue full, replica shutting down) or
    that reached no server (UNAVAILABLE) is repeated as retry says (RetryPolicy(max_attempts=1):
    never). A job is repeated whole: the service keeps nothing of a refused or broken one."""

    def __init__(self, target: str, credentials: Optional[grpc.ChannelCredentials] = None, *,
                 timeout: float = 300.0, retry: RetryPolicy = RetryPolicy()):
        # Round-robin over every address of the target (ipv4:a:p,b:p or dns:///name:port).
        options = [("grpc.lb_policy_name", "round_robin")]
        self._channel = (grpc.secure_channel(target, credentials, options) if credentials
                         else grpc.insecure_channel(target, options))
        self._stub = pb_grpc.ScanPrepStub(self._channel)
        self.timeout, self.retry = timeout, retry

    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _call(self, attempt: Callable[[float], T], timeout: Optional[float]) -> T:
        """attempt(seconds left) with the retries and the deadline, its RpcError as a
        ScanprepError whose cause is the RpcError."""
        def translated(seconds: float):
            try:
                return attempt(seconds)
            except grpc.RpcError as e:
                raise error_from_rpc(e) from e
        return call_with_retries(translated, self.retry,
                                 self.timeout if timeout is None else timeout)

    def info(self, timeout: Optional[float] = None) -> pb.GetInfoResponse:
        return self._call(lambda seconds: self._stub.GetInfo(pb.GetInfoRequest(),
                                                             timeout=seconds), timeout)

    def process(self, scans: Sequence[Scan], *, unit: str,
                stages: Optional[Sequence[str]] = None,
                params: Optional[Mapping[str, object]] = None, preset: str = "",
                include_removed: bool = False,
                labels: Optional[Mapping[str, str]] = None, budget_seconds: float = 0.0,
                job_id: str = "", timeout: Optional[float] = None,
                chunk_points: int = _CHUNK_POINTS,
                progress: Optional[Callable[[pb.Progress], None]] = None,
                origin: Optional[Sequence[float]] = None, strict: bool = False,
                fail_on: Sequence[str] = (), return_source_index: bool = False,
                _result_arrays: int = pb.ARRAY_ENCODING_PACKED) -> Result:
        """Runs one job. unit ("mm", "m", "um", "in") is required, as in the API: a scan in metres
        read as millimetres would be processed with every length 1000 times off. Raises
        ScanprepError when the service refuses or fails it, and when the result arrives
        incomplete or corrupted (its end message's count or CRC-32 disagrees).

        origin (common frame, job unit): the service's local zero; None = the first sent
        points_offset in the common frame, or none when no scan has one (the job is then sent as
        before origins existed). With an origin, Result.points are origin + local in float64.

        preset: a named set of parameters (info().presets: "metrology", "paper" or the server's
        own per scanner model); params override it.

        strict: fail the job (ScanprepError, FAILED_PRECONDITION, reason = the warning's code) on
        a warning that the request is probably wrong or could not be checked, as `scanprep
        process --strict` (STRICT_WARNING_CODES); fail_on: more codes, e.g. "RADIUS_CAPPED".

        Scan.attributes (a file's colour, a scanner's own scalars) are not sent: the job asks for
        each returned point's position in the upload (Result.source_index, 4 bytes a point, also
        asked by return_source_index=True) and Result.attributes gives back, for the returned
        points, every attribute that all scans have with one dtype; a warning names any other."""
        codes = [c if c.startswith("WARNING_CODE_") else "WARNING_CODE_" + c
                 for c in (list(STRICT_WARNING_CODES) if strict else []) + list(fail_on)]
        if not isinstance(scans, Scan):
            scans = list(scans)  # an iterator is read once, here
        check_scans(scans)
        offsets = [_points_offset(s) for s in scans]
        origin = (_job_origin(scans, offsets) if origin is None
                  else np.asarray(origin, dtype=np.float64).reshape(3))
        points_back = _result_arrays != pb.ARRAY_ENCODING_NONE
        want_index = points_back and (return_source_index or any(s.attributes for s in scans))
        names = _shared_attributes(scans) if want_index else []
        sent = [name for name in _SCANNER_ARRAYS if getattr(scans[0], name) is not None]
        header = _header(scans, offsets, origin, unit, stages, params, preset, include_removed,
                         labels, budget_seconds, job_id, dict.fromkeys(codes), _result_arrays,
                         want_index)

        def attempt(seconds: float) -> Result:
            responses = self._stub.Process(_requests(header, scans, offsets, chunk_points),
                                           timeout=seconds)
            return _result(responses, origin, progress, header.total_points if want_index else 0,
                           sent)
        result = self._call(attempt, timeout)
        if result.source_index is not None:
            result.attributes = _gather(scans, names, result.source_index)
        elif want_index:
            warnings.warn("the service returned no source_index (a server older than "
                          "JobHeader.return_source_index): Result.source_index is None and "
                          "Result.attributes are empty", stacklevel=2)
        return result

    def health(self, scans: Sequence[Scan], *, unit: str, **options) -> Health:
        """The scans' health without cleaning them: the job runs the "health" stage and what it
        needs (as `scanprep health`); options as process's, but stages."""
        if "stages" in options:
            raise ValueError("health runs the \"health\" stage and what it needs: no stages")
        # The answer is the report: no cloud comes back.
        result = self.process(scans, unit=unit, stages=["health"],
                              _result_arrays=pb.ARRAY_ENCODING_NONE, **options)
        if result.health is None:
            raise ScanprepError(grpc.StatusCode.INTERNAL,
                                "the service ran the health stage but reported no health")
        return result.health


_RESULT_ARRAYS = (("xyz", "<f4"), ("scan_index", "<u4"), ("scanline", "<u4"), ("quality", "<f4"),
                  ("intensity", "<f4"), ("normal", "<f4"))


def _array_bytes(chunk: pb.PointChunk, name: str, dtype: str) -> bytes:
    """One array of a chunk as its little-endian bytes, from either form (packed or repeated)."""
    packed = getattr(chunk, f"{name}_packed")
    if packed:
        return packed
    values = getattr(chunk, name)
    return np.array(values, dtype=dtype).tobytes() if len(values) else b""


def _source_index(parts: list[bytes], points: int, uploaded: int) -> Optional[np.ndarray]:
    """The result's source_index, checked against its points and the upload; None when a server
    that predates JobHeader.return_source_index sent none."""
    index = np.frombuffer(b"".join(parts), dtype="<u4")
    if points and not len(index):
        return None
    if len(index) != points or (len(index) and int(index.max()) >= uploaded):
        raise ScanprepError(grpc.StatusCode.DATA_LOSS,
                            f"the result's source_index does not fit: {len(index)} values for "
                            f"{points} points, of {uploaded} uploaded")
    return index.astype(np.uint32)


def _per_point(parts: dict[str, list[bytes]], name: str, dtype: str, points: int,
               per_point: int = 1) -> Optional[np.ndarray]:
    """One optional array of the result, typed and without a copy (a view of the received bytes);
    None when no chunk carried it. An array that is not per_point values for each of the points
    (present in some chunks only, or cut) is DATA_LOSS, as a bad checksum is."""
    if not parts[name]:
        return None
    values = np.frombuffer(b"".join(parts[name]), dtype=dtype)
    if len(values) != per_point * points:
        raise ScanprepError(grpc.StatusCode.DATA_LOSS,
                            f"the result's {name} has {len(values)} values for {points} points")
    return values.reshape(-1, per_point) if per_point > 1 else values


def _result(responses: Iterator[pb.ProcessResponse], origin: Optional[np.ndarray],
            progress: Optional[Callable[[pb.Progress], None]], uploaded: int,
            sent: Sequence[str] = ()) -> Result:
    """The Result of one job's response stream, its checksum verified; with uploaded (the job's
    total_points) > 0 the job asked for source_index. sent names the scanner arrays the job
    uploaded (scanline, quality, intensity): each is an empty array when no point came back."""
    parts: dict[str, list[bytes]] = {name: [] for name, _ in _RESULT_ARRAYS}
    parts["source_index"] = []
    flags: list[bytes] = []
    report = end = None
    crc = 0
    for response in responses:
        kind = response.WhichOneof("kind")
        if kind == "points":
            chunk = response.points
            for name, dtype in _RESULT_ARRAYS:  # the checksum's order: field numbers, then flags
                data = _array_bytes(chunk, name, dtype)
                crc = zlib.crc32(data, crc)
                if data:
                    parts[name].append(data)
            crc = zlib.crc32(chunk.flags, crc)
            flags.append(chunk.flags)
            data = _array_bytes(chunk, "source_index", "<u4")  # after flags (scanprep.proto)
            crc = zlib.crc32(data, crc)
            parts["source_index"].append(data)
        elif kind == "report":
            report = response.report
        elif kind == "end":
            end = response.end
        elif kind == "progress" and progress is not None:
            progress(response.progress)
    points = np.frombuffer(b"".join(parts["xyz"]), dtype="<f4").reshape(-1, 3)
    if report is None or end is None or end.points != len(points) or end.crc32 != crc:
        raise ScanprepError(grpc.StatusCode.DATA_LOSS,
                            f"the result arrived incomplete or corrupted: {len(points)} "
                            f"points, end message {end}")
    normals = _per_point(parts, "normal", "<f4", len(points), 3)
    scanner = {name: _per_point(parts, name, dtype, len(points))
               for name, dtype in _SCANNER_ARRAYS.items()}
    for name in sent:
        if scanner[name] is None and not len(points):
            scanner[name] = np.zeros(0, dtype=_SCANNER_ARRAYS[name])
    flags = np.frombuffer(b"".join(flags), dtype=np.uint8)
    scan_index = (np.frombuffer(b"".join(parts["scan_index"]), dtype="<u4")
                  if parts["scan_index"] else np.zeros(len(points), "<u4"))  # absent: one scan
    if len(flags) != len(points) or len(scan_index) != len(points):
        raise ScanprepError(grpc.StatusCode.DATA_LOSS,
                            f"the result has {len(flags)} flags and {len(scan_index)} scan "
                            f"indices for {len(points)} points")
    if origin is not None:  # the service's local coordinates, back in the caller's frame
        points = points.astype(np.float64) + origin
    source_index = (_source_index(parts["source_index"], len(points), uploaded) if uploaded
                    else None)
    return Result(points=points, normals=normals, flags=flags, scan_index=scan_index,
                  report=report, origin=origin, source_index=source_index, **scanner)
