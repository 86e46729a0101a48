#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
# The hostile-input cases of tools/run-hostile-benchmark.sh, made from clouds `scanprep simulate`
# generated (so every case is the ordinary workload with one thing wrong, not a new generator).
# Usage: hostile_cases.py ORDINARY_DIR PLANE_DIR SCENE_DIR OUT_DIR [DRAWN SEED]
#   ORDINARY_DIR: `simulate --scans 2 -o sim.ply` (sim_frontal.ply, sim_oblique.ply, sim.job.json)
#   PLANE_DIR:    the same with --part plane;  SCENE_DIR: plane.ply (--part plane, one scan, half
#   the points) and sphere.ply (--part sphere, one scan), the parts of the no-pose scene.
#   DRAWN, SEED: that many cases drawn at random from SEED (Cases.drawn: far parts, clusters,
#   lines, offsets and their mixes), after the named ones.
# Writes each case's files under OUT_DIR/CASE/ and prints one line per case on stdout:
#   CASE <TAB> POINTS <TAB> the `scanprep process` arguments, tab-separated (no -o, no --server).
import json
import math
import os
import random
import struct
import sys

TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
         "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
         "float": "f", "float32": "f", "double": "d", "float64": "d"}


def read_ply(path):
    """A binary little-endian vertex-only PLY with scalar properties, as scanprep writes it:
    (property names, list of row lists)."""
    with open(path, "rb") as f:
        names, fmt, count = [], "<", 0
        while (line := f.readline().decode().strip()) != "end_header":
            words = line.split()
            if words[:2] == ["element", "vertex"]:
                count = int(words[2])
            elif words[0] == "property":
                fmt += TYPES[words[1]]
                names.append(words[2])
            elif words[0] == "format" and words[1] != "binary_little_endian":
                sys.exit(f"{path}: {words[1]} PLY, expected binary_little_endian")
        rows = [list(r) for r in struct.iter_unpack(fmt, f.read(struct.calcsize(fmt) * count))]
    return names, fmt, rows


def write_ply(path, names, fmt, rows):
    kinds = {v: k for k, v in TYPES.items() if k in ("uchar", "uint", "float", "double", "int")}
    with open(path, "wb") as f:
        f.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(rows)}\n".encode())
        for name, code in zip(names, fmt[1:]):
            f.write(f"property {kinds[code]} {name}\n".encode())
        f.write(b"end_header\n")
        pack = struct.Struct(fmt).pack
        f.write(b"".join(pack(*r) for r in rows))


def scale_job(job, factor):
    """The job's lengths (positions, spacings, uncertainty) times `factor`: the same scanner
    described in another unit."""
    for scan in job["scans"]:
        for key in ("camera_position", "projector_position"):
            if key in scan:
                scan[key] = {axis: v * factor for axis, v in scan[key].items()}
        for key in ("scanline_spacing", "point_spacing", "uncertainty"):
            if key in scan:
                scan[key] *= factor
    return job


class Cases:
    def __init__(self, ordinary_dir, out_dir):
        self.out = out_dir
        self.job = json.load(open(os.path.join(ordinary_dir, "sim.job.json")))
        self.scans = {s["scan_id"]: read_ply(os.path.join(ordinary_dir, s["scan_id"] + ".ply"))
                      for s in self.job["scans"]}

    def emit(self, case, scans, job, extra=()):
        """Writes `scans` ({stem: (names, fmt, rows)}) and `job` (None: no job file, so no
        scanner metadata) under OUT/case and prints the manifest line."""
        folder = os.path.join(self.out, case)
        os.makedirs(folder)
        args = []
        for stem, (names, fmt, rows) in scans.items():
            args.append(os.path.join(folder, stem + ".ply"))
            write_ply(args[-1], names, fmt, rows)
        if job is not None:
            args += ["--job", os.path.join(folder, "job.json")]
            json.dump(job, open(args[-1], "w"), indent=1)
        points = sum(len(rows) for _, _, rows in scans.values())
        print("\t".join([case, str(points), *args, *extra]))

    def mapped(self, change):
        """Every ordinary scan with change(rows, names) applied to a copy of its rows."""
        out = {}
        for stem, (names, fmt, rows) in self.scans.items():
            copy = [list(r) for r in rows]
            change(copy, names)
            out[stem] = (names, fmt, copy)
        return out

    def far_point(self, distance):
        # One point of the first scan copied to x = distance beside the ordinary cloud.
        scans = self.mapped(lambda rows, names: None)  # copies
        names, _, rows = scans[self.job["scans"][0]["scan_id"]]
        rows.append(list(rows[0]))
        rows[-1][names.index("x")] = distance
        self.emit(f"far_point_{distance:.0e}".replace("+0", ""), scans, self.job)

    def coincident(self, percent):
        # Every (100 / percent)-th point moved onto the scan's first point: one location holding
        # that share of the points, the worst case for a spatial index that splits by position.
        def collapse(rows, names):
            xyz = [names.index(a) for a in "xyz"]
            step = 100 / percent
            for k in range(int(len(rows) * percent / 100)):
                row = rows[int(k * step)]
                for a in xyz:
                    row[a] = rows[0][a]
        self.emit(f"coincident_{percent}pct", self.mapped(collapse), self.job)

    def line(self):
        # All points on the x axis at the job's point spacing, in their scan order.
        spacing = self.job["scans"][0]["point_spacing"]
        counter = iter(range(10**9))

        def flatten(rows, names):
            x, y, z = (names.index(a) for a in "xyz")
            for row in rows:
                row[x], row[y], row[z] = next(counter) * spacing, 0.0, 0.0
        self.emit("line", self.mapped(flatten), self.job)

    def unit_slips(self):
        # Metre data sent as mm: the same scanner in metres (points and job ×1e-3), no --unit.
        def to_metres(rows, names):
            for row in rows:
                for a in (names.index(a) for a in "xyz"):
                    row[a] *= 1e-3
        self.emit("metre_data_as_mm", self.mapped(to_metres),
                  scale_job(json.loads(json.dumps(self.job)), 1e-3))
        # Millimetre data sent as metres: the ordinary files and job with --unit m.
        self.emit("mm_data_as_metres", self.scans, self.job, extra=["--unit", "m"])

    def reexported_scan(self, moved):
        # The first scan sent again as a third scan, every coordinate `moved` mm off (a scan
        # re-exported through decimal text): a repeat within the resolution, SCAN_REPEATED.
        first = self.job["scans"][0]["scan_id"]
        names, fmt, rows = self.scans[first]
        xyz = [names.index(a) for a in "xyz"]
        again = [list(r) for r in rows]
        for row in again:
            for a in xyz:
                row[a] += moved
        job = dict(self.job, scans=self.job["scans"] + [dict(self.job["scans"][0],
                                                             scan_id=first + "_again")])
        self.emit(f"scan_reexported_{moved:g}mm", {**self.scans, first + "_again":
                                                   (names, fmt, again)}, job)

    def scanlines_all_zero(self):
        # Every point on scanline 0 (a reader or client bug): SCANLINES_IMPLAUSIBLE.
        def zero(rows, names):
            line = names.index("scanline")
            for row in rows:
                row[line] = 0
        self.emit("scanlines_all_zero", self.mapped(zero), self.job)

    def one_point_scans(self, scans):
        """`scans` scans of one point each (points of the first scan, with its metadata), alone;
        and the ordinary cloud in `scans` scans, all but its own of one point each. The server's
        default max_scans_per_job is 1,000."""
        first = self.job["scans"][0]["scan_id"]
        names, fmt, rows = self.scans[first]
        step = len(rows) // scans
        singles = {f"single_{n:04d}": (names, fmt, [rows[n * step]]) for n in range(scans)}

        def job(stems):
            return dict(self.job, scans=[dict(self.job["scans"][0], scan_id=s) for s in stems])
        self.emit(f"one_point_scans_{scans}", singles, job(singles))
        extra = dict(list(singles.items())[:scans - len(self.scans)])
        taken = {n * step for n in range(len(extra))}
        ordinary = dict(self.scans)
        ordinary[first] = (names, fmt, [r for i, r in enumerate(rows) if i not in taken])
        ordinary_job = job(extra)
        ordinary_job["scans"] = self.job["scans"] + ordinary_job["scans"]
        self.emit(f"ordinary_in_{scans}_scans", {**ordinary, **extra}, ordinary_job)


    def dense_spots(self):
        """Issue 38's dense spots: the work of a ball grows with the points in it, so these cost
        what a scanner 16x denser would. Deterministic (seeded per case)."""
        first = self.job["scans"][0]["scan_id"]

        def centre():
            names, _, rows = self.scans[first]
            return [rows[0][names.index(a)] for a in "xyz"]

        def in_ball(rng, radius):
            while True:
                d = [rng.uniform(-1, 1) for _ in range(3)]
                if sum(a * a for a in d) <= 1:
                    return [radius * a for a in d]

        # A glint: every 4th / 2nd point moved into a uniform ball of radius 0.05 mm, between the
        # duplicate collapse's cubes (u/100) and u.
        for percent in (25, 50):
            rng = random.Random(percent)
            at = centre()

            def glint(rows, names):
                xyz = [names.index(a) for a in "xyz"]
                for k in range(0, len(rows), 100 // percent):
                    for axis, d in zip(xyz, in_ball(rng, 0.05)):
                        rows[k][axis] = at[xyz.index(axis)] + d
            self.emit(f"dense_ball_{percent}pct_0.05mm", self.mapped(glint), self.job)
        # A cluster: a quarter of the points (a contiguous stretch of each scan) jittered within
        # ±spread of the stretch's middle point.
        for spread in (0.002, 0.01, 0.05):
            rng = random.Random(int(spread * 1e4))

            def cluster(rows, names):
                xyz = [names.index(a) for a in "xyz"]
                start, end = len(rows) // 3, len(rows) // 3 + len(rows) // 4
                at = [rows[(start + end) // 2][a] for a in xyz]
                for row in rows[start:end]:
                    for axis, a in enumerate(xyz):
                        row[a] = at[axis] + rng.uniform(-spread, spread)
            self.emit(f"cluster_25pct_within_{spread}mm", self.mapped(cluster), self.job)
        # Every point at a log-uniform distance 1e-3-1e4 mm from the first, in a random
        # direction: a density spanning fourteen decades (1e4 mm: within what float resolves to
        # u/4 at the ordinary job's u = 0.03 mm; farther is refused, as it must be).
        rng = random.Random(38)
        at = centre()

        def log_radii(rows, names):
            xyz = [names.index(a) for a in "xyz"]
            for row in rows:
                d = [rng.gauss(0, 1) for _ in range(3)]
                norm = math.sqrt(sum(a * a for a in d)) or 1.0
                r = 10 ** rng.uniform(-3, 4)
                for axis, a in enumerate(xyz):
                    row[a] = at[axis] + r * d[axis] / norm
        self.emit("log_radii_1e-3_to_1e4mm", self.mapped(log_radii), self.job)
        # One of the two scans written in inches (or metres) but sent as mm, its job entry in
        # the same unit and without an uncertainty: that scan is 25.4x (1000x) denser.
        for unit, factor in (("inches", 1 / 25.4), ("metres", 1e-3)):
            second = self.job["scans"][1]["scan_id"]
            scans = dict(self.scans)
            names, fmt, rows = scans[second]
            xyz = [names.index(a) for a in "xyz"]
            scans[second] = (names, fmt, [[v * factor if i in xyz else v for i, v in enumerate(r)]
                                          for r in rows])
            job = json.loads(json.dumps(self.job))
            slipped = scale_job({"scans": [job["scans"][1]]}, factor)["scans"][0]
            slipped.pop("uncertainty", None)
            job["scans"][1] = slipped
            self.emit(f"one_scan_in_{unit}", scans, job)

    def parameters_at_their_edges(self):
        """Every costly parameter at its edge together (each alone is a swept case)."""
        edges = {"neighbourhoods.k": 64, "outliers.k": 64, "outliers.method": "loop",
                 "outliers.loop_k": 64, "normals.orientation_k": 64,
                 "normals.radius_mode": "mitra", "normals.mitra_c1": 1000,
                 "normals.mitra_c2": 1000, "neighbourhoods.min_radius_mm": 10000,
                 "correction.radius_scale": 100, "correction.rounds": 1000,
                 "smoothing.iterations": 7}
        extra = [a for name, value in edges.items() for a in ("--param", f"{name}={value}")]
        self.emit("parameters_at_their_edges", self.scans, self.job, extra=extra)

    def drawn(self, rng, number, mix_rng):
        """A case drawn from the hostile classes, each present with probability 1/2 (at least
        one), then, drawn from `mix_rng` (so that a seed draws the same geometry as before these
        two), each with probability 1/2: a density spike (1-50 % of a scan's points uniform in a
        ball of radius 1e-5-0.1 mm, log-uniform: a glint) and a parameter mix (2-4 of the costly
        parameters at values drawn within their ranges; docs/plan-cost.md): a far part (a contiguous stretch of 0.5-30 % of a scan's points moved 1e3-1e9 mm in
        a random direction: a fixture or sphere beside the part); 1-3 clusters of near-identical
        points (1 k-50 k points each, at most a fifth of the cloud, within 1e-7-1e-2 mm,
        log-uniform: some inside a scan's duplicate cubes, some just beyond); a line (a tenth of
        the points 1e-4 mm apart); an offset (the whole job 1e3-5e8 mm from the origin in a
        random direction, written as doubles, as georeferenced data arrives)."""
        classes = []
        while not classes:
            classes = [c for c in ("far", "clusters", "line", "offset") if rng.random() < 0.5]
        total = sum(len(rows) for _, _, rows in self.scans.values())

        def direction():
            v = [rng.gauss(0, 1) for _ in range(3)]
            norm = math.sqrt(sum(a * a for a in v)) or 1.0
            return [a / norm for a in v]
        scans = self.mapped(lambda rows, names: None)  # copies
        stems = list(scans)
        parts = []
        used = {stem: [] for stem in stems}  # (start, end) of the rows each class took

        def region(count, draw=rng):
            """A scan and a stretch of `count` of its rows no other class took (shorter when the
            scan has no such stretch), placed by `draw`."""
            for _ in range(100):
                stem = draw.choice(stems)
                rows = scans[stem][2]
                size = min(count, len(rows))
                start = draw.randrange(0, len(rows) - size + 1)
                if all(start + size <= a or b <= start for a, b in used[stem]):
                    used[stem].append((start, start + size))
                    return scans[stem][0], rows[start:start + size]
                count = max(1, count * 3 // 4)
            return scans[stems[0]][0], []

        if "far" in classes:
            share = rng.uniform(0.005, 0.30)
            names, taken = region(int(share * total))
            count = len(taken)
            distance = 10 ** rng.uniform(3, 9)
            shift = [distance * a for a in direction()]
            for row in taken:
                for axis, a in enumerate(names.index(c) for c in "xyz"):
                    row[a] += shift[axis]
            parts.append(f"far {100 * count / total:.1f}% at {distance:.2g}mm")
        if "clusters" in classes:
            for _ in range(rng.randint(1, 3)):
                names, taken = region(min(total // 5, rng.randint(1000, 50000)))
                if not taken:
                    continue
                count = len(taken)
                jitter = 10 ** rng.uniform(-7, -2)
                xyz = [names.index(c) for c in "xyz"]
                at = [taken[count // 2][a] for a in xyz]
                for row in taken:
                    for axis, a in enumerate(xyz):
                        row[a] = at[axis] + rng.uniform(-jitter, jitter)
                parts.append(f"cluster {count} within {jitter:.1g}mm")
        if "line" in classes:
            names, taken = region(total // 10)
            count = len(taken)
            x, y, z = (names.index(c) for c in "xyz")
            origin = [taken[0][x], taken[0][y], taken[0][z]] if taken else []
            for k, row in enumerate(taken):
                row[x], row[y], row[z] = origin[0] + 1e-4 * k, origin[1], origin[2]
            parts.append(f"line {count} at 1e-4mm")
        job = json.loads(json.dumps(self.job))
        if "offset" in classes:
            distance = 10 ** rng.uniform(3, math.log10(5e8))
            shift = [distance * a for a in direction()]
            for stem in stems:
                names, fmt, rows = scans[stem]
                xyz = [names.index(c) for c in "xyz"]
                for row in rows:
                    for axis, a in enumerate(xyz):
                        row[a] += shift[axis]
                scans[stem] = (names, "<" + "".join(
                    "d" if i in xyz else code for i, code in enumerate(fmt[1:])), rows)
            for scan in job["scans"]:
                for key in ("camera_position", "projector_position"):
                    if key in scan:
                        scan[key] = {axis: v + shift["xyz".index(axis)]
                                     for axis, v in scan[key].items()}
            parts.append(f"offset {distance:.2g}mm")
        extra = []
        if mix_rng.random() < 0.5:
            names, taken = region(int(mix_rng.uniform(0.01, 0.5) * total), mix_rng)
            radius = 10 ** mix_rng.uniform(-5, -1)
            xyz = [names.index(c) for c in "xyz"]
            at = [taken[0][a] for a in xyz] if taken else []
            for row in taken:
                while True:  # uniform in the ball: rejection from its cube
                    d = [mix_rng.uniform(-1, 1) for _ in range(3)]
                    if sum(a * a for a in d) <= 1:
                        break
                for axis, a in enumerate(xyz):
                    row[a] = at[axis] + radius * d[axis]
            parts.append(f"spike {len(taken)} in {radius:.1g}mm")
        if mix_rng.random() < 0.5:
            draws = {"neighbourhoods.k": lambda: str(mix_rng.randint(20, 64)),
                     "neighbourhoods.min_radius_mm": lambda: f"{10 ** mix_rng.uniform(-1, 4):.3g}",
                     "normals.radius_mode=mitra normals.mitra_c2":
                         lambda: f"{10 ** mix_rng.uniform(0, 3):.3g}",
                     "correction.radius_scale": lambda: f"{10 ** mix_rng.uniform(0, 2):.3g}",
                     "smoothing.iterations": lambda: str(mix_rng.randint(1, 7))}
            chosen = mix_rng.sample(sorted(draws), mix_rng.randint(2, 4))
            for name in chosen:
                value = draws[name]()
                *fixed, last = name.split()
                for setting in [*fixed, f"{last}={value}"]:
                    extra += ["--param", setting]
                parts.append(f"{last.split('.')[-1]}={value}")
        self.emit(f"drawn_{number:03d}:" + ",".join(p.replace(" ", "_") for p in parts),
                  scans, job, extra=extra)


def no_pose_scene(scene_dir, cases, points):
    """A generated equivalent of rs1: one unorganized scan (x y z only, no job metadata, so no
    camera, view direction or scanlines) of a floor twenty times the plane part's size with spheres
    standing on it, each clear of the others, together about `points` points."""
    _, _, plane = read_ply(os.path.join(scene_dir, "plane.ply"))
    _, _, sphere = read_ply(os.path.join(scene_dir, "sphere.ply"))
    rows = [[20 * r[0], 20 * r[1], r[2]] for r in plane]
    spheres = max(1, (points - len(rows)) // len(sphere))
    side = math.ceil(math.sqrt(spheres))
    for k in range(spheres):  # a grid of spheres 40 mm apart, 5 mm above the floor
        dx, dy = (40 * (k % side - (side - 1) / 2), 40 * (k // side - (side - 1) / 2))
        rows += [[r[0] + dx, r[1] + dy, r[2] + 15] for r in sphere]
    cases.emit("no_pose_unorganized", {"scene": (["x", "y", "z"], "<fff", rows)}, None)


def main():
    ordinary_dir, plane_dir, scene_dir, out_dir = sys.argv[1:5]
    cases = Cases(ordinary_dir, out_dir)
    cases.emit("ordinary", cases.scans, cases.job)
    cases.far_point(1e6)
    cases.far_point(1e8)
    cases.coincident(10)
    cases.coincident(50)
    cases.line()
    plane = Cases(plane_dir, out_dir)
    plane.emit("plane", plane.scans, plane.job)
    cases.unit_slips()
    no_pose_scene(scene_dir, cases, sum(len(r) for _, _, r in cases.scans.values()))
    cases.one_point_scans(1000)
    cases.reexported_scan(1e-4)
    cases.scanlines_all_zero()
    cases.dense_spots()
    cases.parameters_at_their_edges()
    if len(sys.argv) > 6:
        drawn, seed = int(sys.argv[5]), int(sys.argv[6])
        rng, mix_rng = random.Random(seed), random.Random(seed + 1)
        for number in range(drawn):
            cases.drawn(rng, number, mix_rng)


if __name__ == "__main__":
    main()
