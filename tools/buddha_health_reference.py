#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""The reference for `scanprep health` on real scans (issue 32, docs/health.md "Real scans: Happy
Buddha"): the five Happy Buddha range scans, registered by their .conf, pair by pair aligned with
Open3D's point-to-plane ICP. For each overlapping pair it prints the residual metric of
`scanprep health` (median and 1.4826·MAD of n_f·(p_m − p_f), p_f the fixed scan's nearest point
to a moving point p_m within the overlap distance, n_f its normal) under the .conf's
registration and again after ICP, and what the ICP moved: the misalignment it implies, in the
convention of PairHealth (the rigid motion that maps fixed onto moving: the inverse of ICP's
correction), as a translation at the overlap's centroid (µm) and a rotation vector (degrees).

With --health_json (the report `scanprep health --report_json` wrote for the same scans) it
also undoes each pair's misalignment as `health` estimated it and measures the residual again:
how much of the misregistration the service's own estimate accounts for.

A measurement script, not a test and not a build dependency: it needs Debian's python3-open3d
(apt-get install python3-open3d) and the shared data (../shared/data, or --data), and exits 0
saying what is missing when either is absent. Run: /usr/bin/python3 tools/buddha_health_reference.py
"""

import argparse
import itertools
import pathlib
import sys

import numpy as np

SCANS = ["happyStandRight_264", "happyStandRight_288", "happyStandRight_312",
         "happyStandRight_336", "happyStandRight_24"]
MIN_OVERLAP = 1000   # as the health stage's health.min_overlap_points default
PAIR_SPACINGS = 2.0  # overlap distance in the fixed scan's spacings (health.max_pair_distance)
NORMAL_K = 20        # neighbours of a normal fit (neighbourhoods.k's default)
MAD_TO_SIGMA = 1.4826


def read_conf(path: pathlib.Path) -> dict:
    """scanalyze's `bmesh FILE tx ty tz qx qy qz qw`: X_common = R(q̄)·X + t (core/io/conf.cc)."""
    poses = {}
    for line in path.read_text().splitlines():
        f = line.split()
        if len(f) == 9 and f[0] == "bmesh":
            t = np.array(f[2:5], dtype=float)
            qx, qy, qz, qw = map(float, f[5:9])
            poses[pathlib.Path(f[1]).stem] = (quaternion_matrix(-qx, -qy, -qz, qw), t)
    return poses


def quaternion_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    n = np.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def read_scan(o3d, path: pathlib.Path, rotation: np.ndarray, translation: np.ndarray):
    """The scan in the common frame in millimetres, its normals fitted on NORMAL_K neighbours and
    turned toward the scanner (+z of the scan's own frame, the Stanford range scans' view)."""
    points = np.asarray(o3d.io.read_point_cloud(str(path)).points)
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(1000.0 * (points @ rotation.T + translation))
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(NORMAL_K))
    cloud.orient_normals_to_align_with_direction(rotation @ np.array([0.0, 0.0, 1.0]))
    return cloud


def robust(values: np.ndarray) -> tuple[float, float]:
    median = float(np.median(values))
    return median, MAD_TO_SIGMA * float(np.median(np.abs(values - median)))


def residuals(o3d, fixed, moving, distance: float, transform: np.ndarray):
    """n_f·(T·p_m − p_f) over the moving points whose nearest fixed point lies within
    `distance`, and those moved points."""
    match = o3d.pipelines.registration.evaluate_registration(moving, fixed, distance, transform)
    pairs = np.asarray(match.correspondence_set)
    if len(pairs) == 0:
        return np.zeros(0), np.zeros((0, 3))
    p = np.asarray(moving.points)[pairs[:, 0]] @ transform[:3, :3].T + transform[:3, 3]
    q = np.asarray(fixed.points)[pairs[:, 1]]
    n = np.asarray(fixed.normals)[pairs[:, 1]]
    return np.einsum("ij,ij->i", p - q, n), p


def rotation_vector_deg(rotation: np.ndarray) -> np.ndarray:
    angle = np.arccos(np.clip((np.trace(rotation) - 1) / 2, -1, 1))
    if angle < 1e-12:
        return np.zeros(3)
    axis = np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0],
                     rotation[1, 0] - rotation[0, 1]]) / (2 * np.sin(angle))
    return np.degrees(angle) * axis


def rotation_matrix(vector_deg: np.ndarray) -> np.ndarray:
    """Rodrigues: the rotation by |v| degrees about v."""
    angle = np.radians(np.linalg.norm(vector_deg))
    if angle < 1e-15:
        return np.eye(3)
    k = np.radians(vector_deg) / angle
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross


def health_corrections(path: pathlib.Path) -> dict:
    """Per (fixed, moving) scan id: the 4×4 transform that undoes PairHealth's misalignment
    x ↦ R(x − c) + c + t (fixed onto moving; the job had no origin, so c is in the common
    frame): y ↦ Rᵀ(y − c − t) + c."""
    import json
    corrections = {}
    for pair in json.loads(path.read_text())["health"]["pairs"]:
        def vec(name):
            return np.array([pair.get(name, {}).get(a, 0.0) for a in "xyz"])
        rotation, centre, t = rotation_matrix(vec("rotation_deg")), vec("centre"), vec("translation_mm")
        undo = np.eye(4)
        undo[:3, :3] = rotation.T
        undo[:3, 3] = centre - rotation.T @ (centre + t)
        corrections[(pair["fixed_scan_id"], pair["moving_scan_id"])] = undo
    return corrections


def main() -> int:
    here = pathlib.Path(__file__).resolve().parents[1]
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=pathlib.Path,
                        default=here.parent / "shared" / "data" / "stanford_happy_stand_range_scans")
    parser.add_argument("--health_json", type=pathlib.Path,
                        help="scanprep health --report_json of the same scans: also undo its "
                             "estimate and measure again")
    args = parser.parse_args()
    try:
        import open3d as o3d
    except ImportError:
        print("skipped: open3d is not installed (Debian: apt-get install python3-open3d)")
        return 0
    conf = args.data / "happyStandRight.conf"
    if not conf.exists():
        print(f"skipped: {conf} not found (the shared data; --data DIR)")
        return 0
    poses = read_conf(conf)
    clouds = {name: read_scan(o3d, args.data / f"{name}.ply", *poses[name]) for name in SCANS}
    estimation = o3d.pipelines.registration.TransformationEstimationPointToPlane()
    criteria = o3d.pipelines.registration.ICPConvergenceCriteria(max_iteration=100)
    undo = health_corrections(args.health_json) if args.health_json else {}
    print("| fixed | moving | overlap | conf: median µm | conf: spread µm | ICP: median µm | "
          "ICP: spread µm | ICP-implied t µm (x, y, z) | ICP-implied r ° (x, y, z) |" +
          (" health undone: median µm | health undone: spread µm |" if undo else ""))
    print("|---|---|---:|---:|---:|---:|---:|---|---|" + ("---:|---:|" if undo else ""))
    for fixed_name, moving_name in itertools.combinations(SCANS, 2):
        fixed, moving = clouds[fixed_name], clouds[moving_name]
        spacing = float(np.median(np.asarray(fixed.compute_nearest_neighbor_distance())))
        distance = PAIR_SPACINGS * spacing
        before, p = residuals(o3d, fixed, moving, distance, np.eye(4))
        if len(before) < MIN_OVERLAP:
            continue
        icp = o3d.pipelines.registration.registration_icp(moving, fixed, distance, np.eye(4),
                                                          estimation, criteria)
        after, _ = residuals(o3d, fixed, moving, distance, icp.transformation)
        # ICP's correction C maps moving onto fixed; the misalignment is C⁻¹, at the centroid c
        # of the overlap: x ↦ R⁻¹(x − c) + c + t_c.
        inverse = np.linalg.inv(icp.transformation)
        centre = p.mean(axis=0)
        t_centre = inverse[:3, :3] @ centre + inverse[:3, 3] - centre
        r = rotation_vector_deg(inverse[:3, :3])
        (m0, s0), (m1, s1) = robust(before), robust(after)
        undone = ""
        if (fixed_name, moving_name) in undo:
            m2, s2 = robust(residuals(o3d, fixed, moving, distance,
                                      undo[(fixed_name, moving_name)])[0])
            undone = f" {1000 * m2:.1f} | {1000 * s2:.1f} |"
        print(f"| {fixed_name.split('_')[1]}° | {moving_name.split('_')[1]}° | {len(before)} | "
              f"{1000 * m0:.1f} | {1000 * s0:.1f} | {1000 * m1:.1f} | {1000 * s1:.1f} | "
              f"{', '.join(f'{1000 * v:.0f}' for v in t_centre)} | "
              f"{', '.join(f'{v:.4f}' for v in r)} |{undone}")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
